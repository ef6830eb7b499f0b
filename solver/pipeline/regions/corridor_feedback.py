"""Joined, not chained (issue 44): where the network leaves a strip no room fits, the
network is planned again with that strip's corridor moved, instead of handing the rooms
a strip that breaks their constraints. A strip is too thin when it is shallower across
than every room's least side (`min_size`); its corridor runs along a grid line. When
that line is no exit's or core's (an anchor), the line is left out of the second grid,
so its two cells are one, deep enough for a row (the pitch raised there); otherwise the
mesh edges along the strip on that line are forbidden, but for those at an exit."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from shapely.geometry import Polygon

from floorplan.models import Problem
from floorplan.solver.network import Mesh

#: Metres within which a corridor's side is taken to lie along a strip's side.
ALONG = 0.05

XY = tuple[float, float]


def least_side(problem: Problem) -> float | None:
    """The least side any room may have (the smallest of the rooms' `min_size`), or
    None when no room bounds its size from below."""
    sides = [min(r.min_size) for r in problem.rooms if r.min_size]
    return min(sides) if sides else None


def too_thin(
    strips: Iterable[Polygon], across: Callable[[Polygon], tuple[int, float]], least: float
) -> list[Polygon]:
    """The strips shallower across (`across`: the axis across and the extent along it)
    than `least` metres: no room of the floor fits them."""
    return [s for s in strips if across(s)[1] < least - 1e-6]


@dataclass(frozen=True)
class Widening:
    """What the second grid changes: inner lines moved, (from, to) per axis (x, y),
    and mesh edges forbidden, by their end points."""

    moved: tuple[tuple[tuple[float, float], ...], tuple[tuple[float, float], ...]] = ((), ())
    forbid: frozenset[tuple[XY, XY]] = frozenset()

    def __bool__(self) -> bool:
        return bool(self.moved[0] or self.moved[1] or self.forbid)


def widening(
    mesh: Mesh,
    active: Sequence[int],
    sinks: Sequence[int],
    thin: Iterable[tuple[Polygon, int]],
    width: float,
    anchored: tuple[Sequence[float], Sequence[float]],
    pitch: tuple[float, float],
) -> Widening:
    """For each thin strip (with its axis across: 1, a row along a corridor running
    along x; 0, a column), the grid line of the active corridor along its long side:
    moved to `pitch` from the strip's far side when it is an inner line no anchor lies
    on (left out where that reaches the next line but half a pitch), else its mesh
    edges along the strip forbidden (not those at a sink: the exit must stay
    reachable)."""
    moved: tuple[dict[float, float], dict[float, float]] = ({}, {})
    forbid: set[tuple[XY, XY]] = set()
    lines = (mesh.xs, mesh.ys)
    for strip, axis in thin:
        lo, hi = (strip.bounds[axis], strip.bounds[axis + 2])
        a, b = strip.bounds[1 - axis], strip.bounds[3 - axis]  # its extent along
        for line in (lo - width / 2, hi + width / 2):
            along = [
                x for x in active
                if _on_line(mesh, x, axis, line) and _overlap(mesh, x, 1 - axis, a, b)
            ]
            if not along:
                continue
            grid = lines[axis]
            k = min(range(len(grid)), key=lambda k: abs(grid[k] - line))
            inner = 0 < k < len(grid) - 1
            if inner and all(abs(grid[k] - f) > ALONG for f in anchored[axis]):
                step = pitch[axis]
                # Merged with the next line when the move gains nothing (a pitch no
                # deeper than the strip) or comes within half a pitch of it.
                if line > hi:  # the corridor beyond the strip's high side
                    to, nxt = lo + step, grid[k + 1]
                    fits = grid[k] + ALONG < to <= nxt - step / 2
                else:
                    to, nxt = hi - step, grid[k - 1]
                    fits = nxt + step / 2 <= to < grid[k] - ALONG
                moved[axis][grid[k]] = to if fits else nxt
                continue
            for x in (x for x in range(len(mesh.edges))
                      if _on_line(mesh, x, axis, line) and _overlap(mesh, x, 1 - axis, a, b)):
                i, j = mesh.edges[x]
                if i not in sinks and j not in sinks:
                    forbid.add((mesh.points[i], mesh.points[j]))
    return Widening((tuple(moved[0].items()), tuple(moved[1].items())), frozenset(forbid))


def forbidden_edges(mesh: Mesh, forbid: frozenset[tuple[XY, XY]]) -> list[int]:
    """The indices of `mesh`'s edges among `forbid` (by their end points)."""
    def key(p: XY) -> tuple[float, float]:
        return (round(p[0], 6), round(p[1], 6))

    wanted = {frozenset((key(p), key(q))) for p, q in forbid}
    return [
        x for x, (i, j) in enumerate(mesh.edges)
        if frozenset((key(mesh.points[i]), key(mesh.points[j]))) in wanted
    ]


def _on_line(mesh: Mesh, edge: int, axis: int, line: float) -> bool:
    """Whether `edge` runs along the grid line at `line` on `axis` (both ends on it)."""
    i, j = mesh.edges[edge]
    return all(abs(mesh.points[v][axis] - line) <= ALONG for v in (i, j))


def _overlap(mesh: Mesh, edge: int, axis: int, a: float, b: float) -> bool:
    """Whether `edge` overlaps [a, b] along `axis` by more than a hair."""
    i, j = mesh.edges[edge]
    p, q = sorted((mesh.points[i][axis], mesh.points[j][axis]))
    return min(q, b) - max(p, a) > 1e-3 and not math.isclose(p, q)
