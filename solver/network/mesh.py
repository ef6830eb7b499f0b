"""The mesh a network is chosen from (Peng et al. Sec. 4.1, "the input problem domain ...
is discretized into a polygonal mesh M"): a grid of square-ish cells over the free floor.

Vertices are the grid points on or inside the free floor; edges join neighbouring grid
points along a segment inside it. Edges lying along the outline or an obstacle's side are
left out (a corridor centred on a wall would be half outside), as the paper leaves out its
boundary edges (Fig. 2); vertices on the outline stay, so an exit there is a sink reached by
the edge running inwards from it. Pure geometry, no SCIP.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

#: Distances below this (metres) are one point.
EPS = 1e-6

XY = tuple[float, float]


@dataclass(frozen=True)
class Mesh:
    """A graph embedded in the plane: `points` by vertex index, `edges` as (i, j) with
    i < j, and the pairs of opposite edges of each grid cell (`opposite`: two corridors
    a cell apart, the paper's "edges too close", Eq. 12)."""

    points: list[XY]
    edges: list[tuple[int, int]]
    opposite: list[tuple[int, int]] = field(default_factory=list)
    pitch: tuple[float, float] = (1.0, 1.0)  # the mean cell size along x and y
    #: Per grid cell inside the floor, the mesh edges on its sides (its outline sides are
    #: not mesh edges).
    faces: list[list[int]] = field(default_factory=list)
    #: The grid lines' positions along x and y (cells may differ in size).
    xs: tuple[float, ...] = ()
    ys: tuple[float, ...] = ()
    #: Per face, its grid cell's box (x0, y0, x1, y1), in the order of `faces`.
    cells: list[tuple[float, float, float, float]] = field(default_factory=list)

    @property
    def lengths(self) -> list[float]:
        return [math.dist(self.points[i], self.points[j]) for i, j in self.edges]

    def incident(self) -> list[list[int]]:
        """Per vertex, the indices of its edges."""
        out: list[list[int]] = [[] for _ in self.points]
        for x, (i, j) in enumerate(self.edges):
            out[i].append(x)
            out[j].append(x)
        return out

    def other(self, edge: int, vertex: int) -> int:
        i, j = self.edges[edge]
        return j if vertex == i else i

    def nearest(self, point: XY, *, with_edges: bool = True) -> int:
        """The vertex nearest `point` (among those with an edge, by default)."""
        incident = self.incident()
        candidates = [v for v in range(len(self.points)) if incident[v] or not with_edges]
        return min(candidates, key=lambda v: math.dist(self.points[v], point))


def grid_mesh(
    free: BaseGeometry,
    pitch: float | tuple[float, float],
    *,
    anchors: Sequence[XY] = (),
    thinnest: float = 0.5,
    spread: bool | tuple[bool, bool] = False,
    moved: tuple[Sequence[tuple[float, float]], Sequence[tuple[float, float]]] = ((), ()),
) -> Mesh:
    """The grid mesh of `free` at about `pitch` metres (one for both axes, or per axis:
    x, y). Along an axis with an anchor (an exit) strictly inside the floor's extent, the
    grid lines run from that anchor at the pitch both ways, and a last cell thinner than
    `thinnest` pitches joins its neighbour (so the exit lies on a grid line and the cells
    keep the pitch, the outer ones up to 1 + `thinnest`; further anchors get a line of
    their own where the cells allow, `_onto_anchors`); else the extent is cut into whole
    cells, the count the nearest to the pitch, preferring counts that put the anchors
    on grid lines. With `spread`, each stretch between two anchors' lines (or an anchor's
    and the floor's edge) is cut into whole cells instead (`_spread`; per axis: x, y).
    `moved` (per axis, x then y): inner lines moved, (from, to); the lines are kept in
    order, a line moved onto another is one."""
    x0, y0, x1, y1 = free.bounds
    ax, ay = pitch if isinstance(pitch, tuple) else (pitch, pitch)
    sx, sy = spread if isinstance(spread, tuple) else (spread, spread)
    xs = (_spread if sx else _lines)(x0, x1, ax, [a[0] for a in anchors], thinnest)
    ys = (_spread if sy else _lines)(y0, y1, ay, [a[1] for a in anchors], thinnest)
    xs, ys = _moved(xs, moved[0]), _moved(ys, moved[1])
    nx, ny = len(xs) - 1, len(ys) - 1
    px, py = (x1 - x0) / nx, (y1 - y0) / ny
    grown = free.buffer(EPS, join_style="mitre")
    shapely.prepare(grown)
    boundary = free.boundary
    index: dict[tuple[int, int], int] = {}
    points: list[XY] = []
    for i in range(nx + 1):
        for j in range(ny + 1):
            p = (xs[i], ys[j])
            if grown.contains(Point(p)):
                index[(i, j)] = len(points)
                points.append(p)
    edges: list[tuple[int, int]] = []
    edge_at: dict[tuple[int, int, int], int] = {}  # (i, j, 0 east | 1 north) -> edge
    for (i, j), v in index.items():
        for d, (di, dj) in enumerate(((1, 0), (0, 1))):
            w = index.get((i + di, j + dj))
            if w is None:
                continue
            segment = LineString([points[v], points[w]])
            if not grown.contains(segment):
                continue
            if boundary.distance(segment.interpolate(0.5, normalized=True)) <= EPS:
                continue  # along a wall
            edge_at[(i, j, d)] = len(edges)
            edges.append((min(v, w), max(v, w)))
    opposite = []
    faces = []
    cells = []
    for i in range(nx):
        for j in range(ny):
            for a, b in (((i, j, 0), (i, j + 1, 0)), ((i, j, 1), (i + 1, j, 1))):
                if a in edge_at and b in edge_at:
                    opposite.append((edge_at[a], edge_at[b]))
            centre = Point((xs[i] + xs[i + 1]) / 2, (ys[j] + ys[j + 1]) / 2)
            if grown.contains(centre):
                sides = [
                    edge_at[k]
                    for k in ((i, j, 0), (i, j + 1, 0), (i, j, 1), (i + 1, j, 1))
                    if k in edge_at
                ]
                faces.append(sides)
                cells.append((xs[i], ys[j], xs[i + 1], ys[j + 1]))
    return Mesh(points, edges, opposite, (px, py), faces, tuple(xs), tuple(ys), cells)


def _lines(
    lo: float, hi: float, pitch: float, anchors: Sequence[float], thinnest: float
) -> list[float]:
    """The grid lines across [lo, hi] (docstring of `grid_mesh`)."""
    edge = pitch * thinnest
    inside = [a for a in anchors if lo + edge < a < hi - edge]
    if not inside or hi - lo < 2 * pitch:
        n = _cells(hi - lo, pitch, [a - lo for a in anchors])
        return [lo + k * (hi - lo) / n for k in range(n)] + [hi]
    a = inside[0]
    below = math.floor((a - lo) / pitch + 1e-9)
    above = math.floor((hi - a) / pitch + 1e-9)
    lines = [a + k * pitch for k in range(-below, above + 1)]
    inner = [x for x in lines if lo + edge - EPS < x < hi - edge + EPS]
    return _onto_anchors([lo, *inner, hi], inside, edge)


def _moved(lines: list[float], moves: Sequence[tuple[float, float]]) -> list[float]:
    """`lines` with each inner line at a move's `from` put at its `to` (`grid_mesh`)."""
    if not moves:
        return lines
    out = list(lines)
    for k in range(1, len(out) - 1):
        for old, new in moves:
            if abs(out[k] - old) <= EPS:
                out[k] = new
    return sorted({round(x, 9) for x in out})


def _spread(
    lo: float, hi: float, pitch: float, anchors: Sequence[float], thinnest: float
) -> list[float]:
    """The grid lines across [lo, hi] through every anchor that leaves no stretch
    thinner than `thinnest` pitches (in order of `anchors`), each stretch between two
    of those lines cut into equal cells, as many as make their size nearest the pitch
    (`round(length / pitch)` kept a 7 m stretch one cell at a 4.96 m pitch). Lines
    run from one exit at the pitch left a 6.6 m and a 3.0 m column at the ends of
    office-72-core (its exit on the core in the middle), rows 5.7 and 2.1 m deep for
    rooms 4 m wide (bench/NOTES.md, "Corridors")."""
    edge = pitch * thinnest
    fixed = [lo, hi]
    for a in anchors:
        if lo + edge <= a <= hi - edge and all(abs(a - f) >= edge for f in fixed):
            fixed.append(a)
    if len(fixed) == 2:
        return _lines(lo, hi, pitch, anchors, thinnest)
    fixed.sort()
    out = [lo]
    for a, b in itertools.pairwise(fixed):
        n = min(range(1, max(2, math.ceil((b - a) / pitch)) + 1),
                key=lambda n: abs((b - a) / n - pitch))
        out += [a + k * (b - a) / n for k in range(1, n + 1)]
    return out


def _onto_anchors(lines: list[float], anchors: Sequence[float], edge: float) -> list[float]:
    """`lines` with a line through each anchor: a line added, else the nearest inner
    line moved onto it, whichever first leaves no cell thinner than `edge`; neither:
    the anchor is left off the grid. With lines only from the first exit, an exit on a
    lift core's side lay 2-3 m off every line and its sink on another vertex, so the
    corridors missed the exit (bench/NOTES.md, "Corridors")."""
    fixed: list[float] = []
    for a in anchors:
        if any(abs(x - a) <= EPS for x in lines):
            fixed.append(a)
            continue
        at = next(k for k in range(1, len(lines)) if lines[k] > a)
        if lines[at - 1] + edge <= a <= lines[at] - edge:
            lines.insert(at, a)
            fixed.append(a)
            continue
        movable = [k for k in range(1, len(lines) - 1)
                   if not any(abs(lines[k] - f) <= EPS for f in fixed)]
        k = min(movable, key=lambda k: abs(lines[k] - a), default=None)
        if k is not None and lines[k - 1] + edge <= a <= lines[k + 1] - edge:
            lines[k] = a
            fixed.append(a)
    return lines


def _cells(length: float, pitch: float, offsets: Sequence[float]) -> int:
    """How many cells cut a side of `length`: near `length / pitch`, preferring counts
    that put the anchors' offsets on grid lines."""
    base = max(1, round(length / pitch))
    choices = range(max(1, base - 2), base + 3)

    def misses(n: int) -> tuple[int, float]:
        step = length / n
        off = [o for o in offsets if EPS < o < length - EPS]
        missed = sum(1 for o in off if abs(o / step - round(o / step)) * step > 1e-3)
        return missed, abs(step - pitch)

    return min(choices, key=misses)


def without(mesh: Mesh, removed: Sequence[int]) -> Mesh:
    """`mesh` less the edges `removed` (indices renumbered; the vertices kept, so sinks
    keep theirs): opposite pairs losing an edge go, and so does a cell left with no side
    (nothing can cover it)."""
    gone = set(removed)
    renumber: dict[int, int] = {}
    edges = []
    for x, edge in enumerate(mesh.edges):
        if x not in gone:
            renumber[x] = len(edges)
            edges.append(edge)
    opposite = [(renumber[a], renumber[b]) for a, b in mesh.opposite
                if a in renumber and b in renumber]
    faces, cells = [], []
    for k, sides in enumerate(mesh.faces):
        kept = [renumber[x] for x in sides if x in renumber]
        if kept:
            faces.append(kept)
            if mesh.cells:
                cells.append(mesh.cells[k])
    return Mesh(mesh.points, edges, opposite, mesh.pitch, faces, mesh.xs, mesh.ys, cells)


def cell_polygon(
    mesh: Mesh, edges: Sequence[int], width: float, free: BaseGeometry
) -> BaseGeometry:
    """The corridor floor of `edges`: each edge's centre line widened to `width` (square
    ends, mitred joins), united and clipped to the free floor."""
    if not edges:
        return Polygon()
    lines = [
        LineString([mesh.points[mesh.edges[x][0]], mesh.points[mesh.edges[x][1]]]) for x in edges
    ]
    shape = shapely.union_all(
        [line.buffer(width / 2, cap_style="square", join_style="mitre") for line in lines]
    )
    return shape.intersection(free)
