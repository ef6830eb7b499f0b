"""A first layout by slicing, for problems whose rooms ask only for sizes and guide
points (issue 7: a constructive start).

The free floor is cut into rectangles (`rectangles_of`), each rectangle into rows,
and the rooms are dealt to the rows by target area, a room with a guide point into
the row that holds it. With that order fixed, the rooms of a row side by side fill it
exactly and the rows stacked fill their rectangle, so inside (Eq. 1), non-overlap
(Eq. 2) and full coverage hold by construction, and what is left is a small convex QP:
the row heights and room widths that minimise E_size (Eq. 6) under C_size (Eq. 5),
C_ratio (Eq. 7, each room keeping the orientation of its target) and C_pos (Eq. 8),
all linear once the order is known. A layout of 150 rooms comes out complete and
fully covering in well under a second, where the MIQP needs many seconds for a first,
partly covering one.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from pyscipopt import Model, quicksum

from models import Problem, Room
from solver.geometry import Box, Domain, rectangles_of

#: Row counts tried per region, relative to the region's depth over the typical
#: target depth; the plan with the least E_size wins.
ROW_TRIES = (0, -1, 1)
#: Passes of the dealing's hill-climb; each tries every loose room in every other row.
BALANCE_PASSES = 4
#: An empty row smaller than this (m²) costs nothing: it is dropped and its region's
#: other rows take its depth.
MIN_ROW_AREA = 1e-9


@dataclass
class _Row:
    region: Box  # the rectangle of free floor the row is a band of
    band: Box  # the row as planned; the QP then sets its height
    rooms: list[Room] = field(default_factory=list)

    @property
    def pinned(self) -> list[Room]:
        return [r for r in self.rooms if r.positions]


def slicing_applies(problem: Problem) -> bool:
    """Slicing honours sizes, aspect ratios and guide points, nothing that couples rooms
    (adjacency) or ties them to the outline (boundary)."""
    return not problem.adjacency and not any(room.boundary for room in problem.rooms)


def slicing_layout(
    problem: Problem, domain: Domain, *, deadline: float
) -> dict[str, Box] | None:
    """One rectangle per room filling the free floor, with the least E_size among a
    few row counts; None when no row plan admits the rooms' bounds."""
    regions = [r for r in sorted(rectangles_of(domain.free), key=lambda b: (b.y0, b.x0))
               if _can_host_a_room(problem.rooms, r)]
    if not regions:
        return None
    # The side of a room with no target nor maximum: the floor shared out evenly.
    typical = math.sqrt(sum(r.area for r in regions) / len(problem.rooms))
    best: tuple[float, dict[str, Box]] | None = None
    for shift in ROW_TRIES:
        if time.monotonic() >= deadline:
            break
        rows = _plan_rows(problem, regions, shift, typical)
        if rows is None:
            continue
        solved = _size_rows(rows, typical, deadline=deadline)
        if solved is not None and (best is None or solved[0] < best[0]):
            best = solved
    return None if best is None else best[1]


def _can_host_a_room(rooms: Sequence[Room], region: Box) -> bool:
    return any(_bounds(r)[0][0] <= region.width and _bounds(r)[1][0] <= region.depth
               for r in rooms)


def _bounds(room: Room) -> tuple[tuple[float, float], tuple[float, float]]:
    """(min, max) width and (min, max) depth of a room; unbounded means the domain."""
    lo = room.min_size or (0.0, 0.0)
    hi = room.max_size or (math.inf, math.inf)
    return (lo[0], hi[0]), (lo[1], hi[1])


def _target(room: Room, typical: float) -> tuple[float, float]:
    return room.target_size or room.max_size or (typical, typical)


def _plan_rows(
    problem: Problem, regions: list[Box], shift: int, typical: float
) -> list[_Row] | None:
    """Rows per region from the typical target depth (`shift` more or fewer), rooms
    dealt by area: pinned rooms to the row holding their points, the others deepest
    first so that rooms of one row want similar depths."""
    free_area = sum(r.area for r in regions)
    depth = statistics.median(_target(r, typical)[1] for r in problem.rooms)
    rows: list[_Row] = []
    for region in regions:
        count = max(1, round(region.depth / depth) + shift)
        step = region.depth / count
        rows += [_Row(region, Box(region.x0, region.y0 + k * step, region.x1,
                                  region.y0 + (k + 1) * step))
                 for k in range(count)]
    loose: list[Room] = []
    for room in problem.rooms:
        if not room.positions:
            loose.append(room)
            continue
        homes = {i for i, row in enumerate(rows)
                 for x, y in room.positions if row.band.contains_point(x, y, tol=0)}
        if len(homes) != 1:
            return None  # points in two rows (or none): not a one-row room
        rows[homes.pop()].rooms.append(room)
    # Rooms fill the floor in proportion to their targets.
    area = sum(math.prod(_target(r, typical)) for r in problem.rooms)
    scale = free_area / area if area > 0 else 1.0
    # The deepest rooms into the deepest rows: a shallow band between obstacles takes
    # the rooms that want to be shallow.
    loose.sort(key=lambda r: -_target(r, typical)[1])
    dealing = sorted(rows, key=lambda row: -row.band.depth)
    for index, row in enumerate(dealing):
        room_area = sum(math.prod(_target(r, typical)) * scale for r in row.rooms)
        last = index == len(dealing) - 1
        while loose and (last or room_area + math.prod(_target(loose[0], typical)) * scale / 2
                         <= row.band.area):
            room = loose.pop(0)
            row.rooms.append(room)
            room_area += math.prod(_target(room, typical)) * scale
    _balance(rows, typical)
    rows = [row for row in rows if row.rooms]
    for row in rows:
        # Along the row by x: pinned rooms where their points are, the others spread
        # evenly in the order they were dealt.
        loose_ids = [r.id for r in row.rooms if not r.positions]
        step = row.band.width / max(1, len(loose_ids))
        slot = {r.id: statistics.mean(x for x, _ in r.positions) if r.positions
                else row.band.x0 + (loose_ids.index(r.id) + 0.5) * step for r in row.rooms}
        row.rooms.sort(key=lambda r: slot[r.id])
    return rows if rows else None


@dataclass
class _Tally:
    """A row's rooms as the sums its estimated E_size needs: count, widths, depths,
    squared depths; moving a room in or out is O(1)."""

    band: Box
    n: int = 0
    widths: float = 0.0
    depths: float = 0.0
    squares: float = 0.0

    def cost(self, n: int, widths: float, depths: float, squares: float) -> float:
        if n == 0:
            return 0.0 if self.band.area < MIN_ROW_AREA else self.band.width ** 2
        h = self.band.depth
        misfit = widths - self.band.width
        return misfit ** 2 / n + n * h * h - 2 * h * depths + squares

    def now(self) -> float:
        return self.cost(self.n, self.widths, self.depths, self.squares)

    def changed(self, out: tuple[float, float] | None, into: tuple[float, float] | None
                ) -> float:
        """The cost with the room of target `out` taken out and `into` put in."""
        n, widths, depths, squares = self.n, self.widths, self.depths, self.squares
        for sign, target in ((-1, out), (1, into)):
            if target is not None:
                n += sign
                widths += sign * target[0]
                depths += sign * target[1]
                squares += sign * target[1] ** 2
        return self.cost(n, widths, depths, squares)

    def apply(self, out: tuple[float, float] | None, into: tuple[float, float] | None
              ) -> None:
        for sign, target in ((-1, out), (1, into)):
            if target is not None:
                self.n += sign
                self.widths += sign * target[0]
                self.depths += sign * target[1]
                self.squares += sign * target[1] ** 2


def _balance(rows: list[_Row], typical: float) -> None:
    """Hill-climb the dealing: move or swap loose rooms between rows while that lowers
    an estimate of E_size with the rows at their planned depths, a row's width misfit
    spread evenly over its rooms (what the QP would do with it)."""
    target = {r.id: _target(r, typical) for row in rows for r in row.rooms}
    tallies = [_Tally(row.band) for row in rows]
    for row, tally in zip(rows, tallies, strict=True):
        for room in row.rooms:
            tally.apply(None, target[room.id])
    for _ in range(BALANCE_PASSES):
        improved = False
        for a, row_a in enumerate(rows):
            for room in [r for r in row_a.rooms if not r.positions]:
                mine = target[room.id]
                cost_a = tallies[a].now()
                best: tuple[float, int, Room | None] = (1e-9, -1, None)
                for b, row_b in enumerate(rows):
                    if b == a:
                        continue
                    base = cost_a + tallies[b].now()
                    # Move the room to row b, or swap it with one of b's loose rooms.
                    gain = base - tallies[a].changed(mine, None) - tallies[b].changed(None, mine)
                    if gain > best[0]:
                        best = (gain, b, None)
                    for other in row_b.rooms:
                        if other.positions:
                            continue
                        theirs = target[other.id]
                        gain = (base - tallies[a].changed(mine, theirs)
                                - tallies[b].changed(theirs, mine))
                        if gain > best[0]:
                            best = (gain, b, other)
                _, b, other = best
                if b < 0:
                    continue
                row_b = rows[b]
                row_a.rooms = [r for r in row_a.rooms if r is not room]
                row_b.rooms = [r for r in row_b.rooms if r is not other]
                row_b.rooms.append(room)
                theirs = None if other is None else target[other.id]
                if other is not None:
                    row_a.rooms.append(other)
                tallies[a].apply(mine, theirs)
                tallies[b].apply(theirs, mine)
                improved = True
        if not improved:
            return


def _size_rows(
    rows: list[_Row], typical: float, *, deadline: float
) -> tuple[float, dict[str, Box]] | None:
    """The convex QP: row heights and room widths minimising E_size (Eq. 6)."""
    m = Model("slicing")
    m.hideOutput()
    m.setParam("limits/time", max(0.05, deadline - time.monotonic()))
    m.setParam("limits/gap", 1e-4)
    heights = []
    widths: dict[str, object] = {}
    errors = []
    for k, row in enumerate(rows):
        depth_lo = max(_bounds(r)[1][0] for r in row.rooms)
        depth_hi = min(_bounds(r)[1][1] for r in row.rooms)
        if depth_lo > min(depth_hi, row.region.depth):
            return None
        h = m.addVar(f"h[{k}]", lb=depth_lo, ub=min(depth_hi, row.region.depth))
        heights.append(h)
        x: Any = float(row.region.x0)  # then an expression: the widths so far
        for room in row.rooms:
            (w_lo, w_hi), _ = _bounds(room)
            w = m.addVar(f"w[{room.id}]", lb=w_lo, ub=min(w_hi, row.region.width))
            widths[room.id] = w
            _c_ratio(m, room, w, h, typical)
            # C_pos (Eq. 8) along the row; across it below, per region.
            for px, _ in room.positions:
                if isinstance(x, float) and x > px:
                    return None  # the row's first room starts east of its point
                if not isinstance(x, float):
                    m.addCons(x <= px, name=f"pos_w[{room.id}]")
                m.addCons(x + w >= px, name=f"pos_e[{room.id}]")
            x = x + w
            if room.target_size is not None:
                e = m.addVar(f"e[{room.id}]", lb=0)
                tw, td = room.target_size
                m.addCons((w - tw) * (w - tw) + (h - td) * (h - td) <= e,
                          name=f"size_error[{room.id}]")
                errors.append(e)
        m.addCons(quicksum(widths[r.id] for r in row.rooms) == row.region.width,
                  name=f"fill_row[{k}]")
    for n, (region, members) in enumerate(_by_region(rows).items()):
        m.addCons(quicksum(heights[k] for k in members) == region.depth,
                  name=f"fill_region[{n}]")
        y: Any = float(region.y0)
        for k in members:
            for room in rows[k].pinned:
                for _, py in room.positions:
                    if isinstance(y, float) and y > py:
                        return None
                    if not isinstance(y, float):
                        m.addCons(y <= py, name=f"pos_s[{room.id}]")
                    m.addCons(y + heights[k] >= py, name=f"pos_n[{room.id}]")
            y = y + heights[k]
    m.setObjective(quicksum(errors) if errors else 0)
    m.optimize()
    if m.getNSols() == 0:
        return None
    sol = m.getBestSol()
    boxes: dict[str, Box] = {}
    for region, members in _by_region(rows).items():
        y = region.y0
        for n, k in enumerate(members):
            # The last row and the last room end exactly on the region's edge.
            y1 = region.y1 if n == len(members) - 1 else y + sol[heights[k]]
            x = region.x0
            for i, room in enumerate(rows[k].rooms):
                x1 = region.x1 if i == len(rows[k].rooms) - 1 else x + sol[widths[room.id]]
                boxes[room.id] = Box(x, y, x1, y1)
                x = x1
            y = y1
    return m.getObjVal(), boxes


def _by_region(rows: list[_Row]) -> dict[Box, list[int]]:
    """Row indices by the region they cut, bottom to top."""
    groups: dict[Box, list[int]] = {}
    for k, row in enumerate(rows):
        groups.setdefault(row.region, []).append(k)
    for members in groups.values():
        members.sort(key=lambda k: rows[k].band.y0)
    return groups


def _c_ratio(m: Model, room: Room, w: object, h: object, typical: float) -> None:
    """C_ratio (Eq. 7) with the orientation of the room's target: linear."""
    if room.aspect_ratio is None:
        return
    lo, hi = room.aspect_ratio
    tw, td = _target(room, typical)
    long, short = (w, h) if tw >= td else (h, w)
    m.addCons(long >= lo * short, name=f"ratio_lo[{room.id}]")
    m.addCons(long <= hi * short, name=f"ratio_hi[{room.id}]")
