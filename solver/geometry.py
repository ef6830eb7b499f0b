"""Plane geometry for layouts: the domain as bounding box minus blocked rectangles
(paper Sec. 5.3), boundary edges with their compass facing, and shapely helpers."""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
import shapely
from shapely.geometry import LineString, MultiPolygon, Polygon, box
from shapely.geometry.base import BaseGeometry

from floorplan.models import Problem, Rect

#: Coordinates are snapped to this grid (metres) when polygons are merged.
GRID = 1e-6
#: Lengths and areas below this count as zero.
EPS = 1e-6
#: A room wrapping an obstacle keeps at least this much floor (metres) beside each side
#: of it away from the outline: a usable strip with walls of its own, never a wall
#: shared with the obstacle's that an adjacency could count as contact.
WRAP_MARGIN = 0.5

Facing = Literal["north", "south", "east", "west"]


class GeometryError(ValueError):
    """Rectangles that do not form the shape they should."""


@dataclass(frozen=True)
class Box:
    """An axis-aligned rectangle by its corners; the solver's constant rectangles."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def depth(self) -> float:
        return self.y1 - self.y0

    @property
    def area(self) -> float:
        return self.width * self.depth

    def to_polygon(self) -> Polygon:
        return box(self.x0, self.y0, self.x1, self.y1)

    def to_rect(self) -> Rect:
        return Rect(x=self.x0, y=self.y0, width=self.width, depth=self.depth)

    @classmethod
    def of(cls, rect: Rect) -> Box:
        return cls(rect.x, rect.y, rect.x + rect.width, rect.y + rect.depth)

    def contains_point(self, x: float, y: float, tol: float = EPS) -> bool:
        return self.x0 - tol <= x <= self.x1 + tol and self.y0 - tol <= y <= self.y1 + tol


@dataclass(frozen=True)
class Edge:
    """Boundary edge `index` from vertex `index` to the next, with its outward facing."""

    index: int
    start: tuple[float, float]
    end: tuple[float, float]
    facing: Facing

    @property
    def horizontal(self) -> bool:
        return self.facing in ("north", "south")

    @property
    def line(self) -> float:
        """The edge's constant coordinate: y for a horizontal edge, x for a vertical one."""
        return self.start[1] if self.horizontal else self.start[0]

    @property
    def span(self) -> tuple[float, float]:
        """The edge's extent along its own direction, low to high."""
        a, b = (self.start[0], self.end[0]) if self.horizontal else (self.start[1], self.end[1])
        return (min(a, b), max(a, b))

    @property
    def length(self) -> float:
        lo, hi = self.span
        return hi - lo


@dataclass(frozen=True)
class Notch:
    """An obstacle standing on the outline (a shaft, a chimney breast), which one
    room's rectangle may enclose: the room then wraps around it, as a bedroom does
    around a shaft in its corner, and a pocket between the obstacle and a wall needs no
    room of its own. `hull` is what the rectangle must then contain: the obstacle and
    `WRAP_MARGIN` beyond each side not on the outline."""

    obstacle: Box
    hull: Box


@dataclass(frozen=True)
class Domain:
    """Where rooms go: the bounding box minus `blocked` rectangles (obstacles and the
    parts of the box outside the outline). The obstacles among them that a room may
    wrap around are also `notches`."""

    bbox: Box
    free: Polygon | MultiPolygon
    blocked: tuple[Box, ...]
    edges: tuple[Edge, ...]
    notches: tuple[Notch, ...] = ()

    @property
    def area(self) -> float:
        return float(self.free.area)

    @cached_property
    def spannable(self) -> BaseGeometry:
        """The floor a room's rectangle may span: the free area and the notches."""
        if not self.notches:
            return self.free
        return shapely.union_all([self.free, *(n.obstacle.to_polygon() for n in self.notches)])

    def gaps(self, boxes: Iterable[Box], larger_than: float) -> list[Polygon]:
        """The parts of the free area none of `boxes` covers, each larger than
        `larger_than` m²."""
        rest = self.free.difference(shapely.union_all([b.to_polygon() for b in boxes]))
        return [g for g in getattr(rest, "geoms", [rest])
                if isinstance(g, Polygon) and g.area > larger_than]


def boundary_edges(boundary: Sequence[tuple[float, float]]) -> tuple[Edge, ...]:
    """Edges of an axis-aligned ring with the compass direction of their outward normal.

    >>> [e.facing for e in boundary_edges([(0, 0), (4, 0), (4, 3), (0, 3)])]
    ['south', 'east', 'north', 'west']
    >>> [e.facing for e in boundary_edges([(0, 0), (0, 3), (4, 3), (4, 0)])]
    ['west', 'north', 'east', 'south']
    """
    ccw = Polygon(boundary).exterior.is_ccw
    edges = []
    n = len(boundary)
    for k in range(n):
        (x0, y0), (x1, y1) = boundary[k], boundary[(k + 1) % n]
        dx, dy = x1 - x0, y1 - y0
        # Outward normal: (dy, -dx) for a counter-clockwise ring, the opposite otherwise.
        nx, ny = (dy, -dx) if ccw else (-dy, dx)
        if abs(nx) > abs(ny):
            facing: Facing = "east" if nx > 0 else "west"
        else:
            facing = "north" if ny > 0 else "south"
        edges.append(Edge(k, (x0, y0), (x1, y1), facing))
    return tuple(edges)


def edges_named(problem: Problem, edges: Sequence[Edge], names: Iterable[int | str]) -> list[Edge]:
    """The edges a room's `boundary` list names: indices, or every edge facing a compass word."""
    chosen: dict[int, Edge] = {}
    for name in names:
        for edge in edges:
            if edge.index == name or edge.facing == name:
                chosen[edge.index] = edge
    return [chosen[k] for k in sorted(chosen)]


def rectangles_of(region: BaseGeometry) -> list[Box]:
    """Split a rectilinear region into few disjoint rectangles (maximal horizontal strips
    merged vertically when they line up).

    >>> rectangles_of(box(0, 0, 4, 3))
    [Box(x0=0.0, y0=0.0, x1=4.0, y1=3.0)]
    >>> l_shape = box(0, 0, 4, 2).union(box(0, 2, 2, 4))
    >>> sorted((b.x0, b.y0, b.x1, b.y1) for b in rectangles_of(l_shape))
    [(0.0, 0.0, 4.0, 2.0), (0.0, 2.0, 2.0, 4.0)]
    """
    if region.is_empty or region.area <= EPS:
        return []
    xs, ys, cells = _grid_cells(region)
    # Horizontal runs of inside cells per row.
    rows: list[list[tuple[float, float]]] = []
    for j in range(len(ys) - 1):
        runs: list[tuple[float, float]] = []
        start: float | None = None
        for i in range(len(xs) - 1):
            inside = bool(cells[j, i])
            if inside and start is None:
                start = xs[i]
            if not inside and start is not None:
                runs.append((start, xs[i]))
                start = None
        if start is not None:
            runs.append((start, xs[-1]))
        rows.append(runs)
    # Stack identical runs of consecutive rows into one rectangle.
    result: list[Box] = []
    open_runs: dict[tuple[float, float], float] = {}
    for j, runs in enumerate(rows):
        current = set(runs)
        for run in list(open_runs):
            if run not in current:
                result.append(Box(run[0], open_runs.pop(run), run[1], ys[j]))
        for run in runs:
            open_runs.setdefault(run, ys[j])
    for run, y0 in open_runs.items():
        result.append(Box(run[0], y0, run[1], ys[-1]))
    return result


def _grid_cells(region: BaseGeometry) -> tuple[list[float], list[float], np.ndarray]:
    """The grid the region's vertex coordinates span, and which of its cells (row by
    y, column by x) are inside the region, tested all at once."""
    coords = shapely.get_coordinates(shapely.boundary(region))
    xs = sorted({round(float(c), 9) for c in coords[:, 0]})
    ys = sorted({round(float(c), 9) for c in coords[:, 1]})
    cx = (np.array(xs[:-1]) + np.array(xs[1:])) / 2
    cy = (np.array(ys[:-1]) + np.array(ys[1:])) / 2
    shapely.prepare(region)
    grid_x, grid_y = np.meshgrid(cx, cy)
    return xs, ys, shapely.contains_xy(region, grid_x, grid_y)


def largest_box_around(region: BaseGeometry, x: float, y: float) -> Box | None:
    """The largest rectangle inside a rectilinear region that holds the point (x, y);
    None when the point is outside. Every span of grid columns around the point is
    tried, each as deep as all its columns reach.

    >>> l_shape = box(0, 0, 10, 2).union(box(0, 2, 3, 4))
    >>> largest_box_around(l_shape, 1, 3)
    Box(x0=0.0, y0=0.0, x1=3.0, y1=4.0)
    >>> largest_box_around(l_shape, 8, 1)
    Box(x0=0.0, y0=0.0, x1=10.0, y1=2.0)
    """
    if region.is_empty or not region.intersects(shapely.Point(x, y)):
        return None
    xs, ys, cells = _grid_cells(region)
    col = min(max(bisect.bisect_right(xs, x) - 1, 0), len(xs) - 2)
    row = min(max(bisect.bisect_right(ys, y) - 1, 0), len(ys) - 2)
    if not cells[row, col]:
        return None

    def reach(i: int) -> tuple[int, int]:
        """Rows [low, high) of the inside run of column i through the point's row."""
        if not cells[row, i]:
            return row, row
        low, high = row, row + 1
        while low > 0 and cells[low - 1, i]:
            low -= 1
        while high < len(ys) - 1 and cells[high, i]:
            high += 1
        return low, high

    runs = [reach(i) for i in range(len(xs) - 1)]
    best: Box | None = None
    for first in range(col, -1, -1):
        if runs[first][0] == runs[first][1]:
            break
        low, high = 0, len(ys) - 1
        for last in range(first, len(xs) - 1):
            if runs[last][0] == runs[last][1]:
                break
            low, high = max(low, runs[last][0]), min(high, runs[last][1])
            if last < col:
                continue
            found = Box(xs[first], ys[low], xs[last + 1], ys[high])
            if best is None or found.area > best.area:
                best = found
    return best


def bounding_box(boxes: Sequence[Box]) -> Box:
    """The smallest box around `boxes`."""
    return Box(min(b.x0 for b in boxes), min(b.y0 for b in boxes),
               max(b.x1 for b in boxes), max(b.y1 for b in boxes))


def unusable_space(region: Box, walls: Sequence[Box], smallest: float) -> tuple[Box, ...]:
    """`region` minus what a room at least `smallest` wide can use among `walls`, as few
    rectangles: slivers between walls then cost no disjunctions. What such a room can
    use is the opening of the free space by a `smallest` square (erode, then dilate,
    by half the side); with rectangles both steps are exact: eroding shrinks the
    region and grows each wall, dilating grows each rectangle of the eroded space.

    >>> unusable_space(Box(0, 0, 4, 2), [Box(0, 0, 1, 2), Box(1.5, 0, 4, 2)], 1.0)
    (Box(x0=0.0, y0=0.0, x1=4.0, y1=2.0),)
    >>> unusable_space(Box(0, 0, 4, 2), [Box(0, 0, 1, 2)], 1.0)
    (Box(x0=0.0, y0=0.0, x1=1.0, y1=2.0),)
    """
    area = region.to_polygon()
    free = area.difference(shapely.union_all([b.to_polygon() for b in walls]))
    half = smallest / 2 * (1 - 1e-6)
    if half > 0:
        core = Box(region.x0 + half, region.y0 + half, region.x1 - half, region.y1 - half)
        if core.width <= 0 or core.depth <= 0:
            return (region,)
        eroded = core.to_polygon().difference(
            shapely.union_all([_grown(b, half).to_polygon() for b in walls])
        )
        opened = shapely.union_all(
            [_grown(b, half).to_polygon() for b in rectangles_of(eroded)]
        )
        free = free.intersection(opened)
    return tuple(rectangles_of(area.difference(free)))


def _grown(b: Box, by: float) -> Box:
    return Box(b.x0 - by, b.y0 - by, b.x1 + by, b.y1 + by)


def make_domain(problem: Problem) -> Domain:
    """The paper's polygonal domain: bounding box minus obstacle rectangles, where the
    part of the box outside the outline is decomposed into rectangles too."""
    outline = problem.outline()
    x0, y0, x1, y1 = outline.bounds
    bbox = Box(x0, y0, x1, y1)
    outside = rectangles_of(bbox.to_polygon().difference(outline))
    obstacles = [Box.of(Rect(x=o.x, y=o.y, width=o.width, depth=o.depth))
                 for o in problem.obstacles]
    return Domain(
        bbox=bbox,
        free=problem.free_area(),
        blocked=tuple(obstacles + outside),
        edges=boundary_edges(problem.boundary),
        notches=notches_of(outline, obstacles, bbox),
    )


def notches_of(outline: Polygon, obstacles: Sequence[Box], bbox: Box) -> tuple[Notch, ...]:
    """The obstacles with a side on the outline, as notches a room may wrap around;
    not those standing on two opposite walls (a room around one would fall in two),
    nor those whose hull leaves the bounding box.

    >>> [n.hull for n in notches_of(box(0, 0, 10, 8), [Box(4, 7, 5, 8.0), Box(4, 3, 5, 4)],
    ...                             Box(0, 0, 10, 8))]
    [Box(x0=3.5, y0=6.5, x1=5.5, y1=8.0)]
    """
    wall = outline.exterior.buffer(EPS)
    found = []
    for b in obstacles:
        sides = {
            "west": ((b.x0, b.y0), (b.x0, b.y1)), "east": ((b.x1, b.y0), (b.x1, b.y1)),
            "south": ((b.x0, b.y0), (b.x1, b.y0)), "north": ((b.x0, b.y1), (b.x1, b.y1)),
        }
        on = {side for side, ends in sides.items() if wall.contains(LineString(ends))}
        if not on or {"west", "east"} <= on or {"south", "north"} <= on:
            continue
        m = WRAP_MARGIN
        hull = Box(b.x0 - (0 if "west" in on else m), b.y0 - (0 if "south" in on else m),
                   b.x1 + (0 if "east" in on else m), b.y1 + (0 if "north" in on else m))
        if (hull.x0 >= bbox.x0 - EPS and hull.y0 >= bbox.y0 - EPS
                and hull.x1 <= bbox.x1 + EPS and hull.y1 <= bbox.y1 + EPS):
            found.append(Notch(b, hull))
    return tuple(found)


def encloses(b: Box, inner: Box) -> bool:
    return (b.x0 <= inner.x0 + EPS and b.y0 <= inner.y0 + EPS
            and b.x1 >= inner.x1 - EPS and b.y1 >= inner.y1 - EPS)


def unwrapped(b: Box, notches: Sequence[Notch]) -> list[Box]:
    """A room's rectangle as the rectangles of its floor: itself, or, where it encloses
    notches, what is left around them, largest first.

    >>> unwrapped(Box(0, 0, 4, 3), [Notch(Box(1, 2, 2, 3), Box(0, 1, 3, 3))])
    [Box(x0=0.0, y0=0.0, x1=4.0, y1=2.0), Box(x0=2.0, y0=2.0, x1=4.0, y1=3.0), \
Box(x0=0.0, y0=2.0, x1=1.0, y1=3.0)]
    """
    inside = [n.obstacle.to_polygon() for n in notches if encloses(b, n.obstacle)]
    if not inside:
        return [b]
    rest = b.to_polygon().difference(shapely.union_all(inside))
    return sorted(rectangles_of(rest), key=lambda r: -r.area)


def shared_wall_length(a: BaseGeometry, b: BaseGeometry) -> float:
    """Length in metres of the boundary two rooms share, all its stretches together
    (an adjacency's contact is one stretch: `longest_shared_wall`).

    >>> shared_wall_length(box(0, 0, 3, 3), box(3, 1, 5, 4))
    2.0
    >>> shared_wall_length(box(0, 0, 1, 1), box(2, 0, 3, 1))
    0.0
    """
    return float(a.boundary.intersection(b.boundary).length)


def longest_shared_wall(a: BaseGeometry, b: BaseGeometry) -> LineString | None:
    """The longest straight stretch of wall two rooms share (a room in pieces, a
    MultiPolygon as a checked layout may hold, has the walls of all its pieces).

    >>> from shapely.geometry import box
    >>> longest_shared_wall(box(0, 0, 3, 3), box(3, 1, 5, 4)).length
    2.0
    """
    shared = a.boundary.intersection(b.boundary)
    segments = [s for s in straight_stretches(shared) if s.length > EPS]
    return max(segments, key=lambda s: s.length, default=None)


def contact_length(a: BaseGeometry, b: BaseGeometry) -> float:
    """The length of `longest_shared_wall` (0 when the rooms share none): an adjacency's
    contact (Eq. 10), one stretch that a door fits in, never the sum of several.

    >>> contact_length(box(0, 0, 3, 3), box(3, 1, 5, 4))
    2.0
    """
    wall = longest_shared_wall(a, b)
    return 0.0 if wall is None else float(wall.length)


def straight_stretches(geometry: BaseGeometry) -> list[LineString]:
    """The straight pieces of a linear geometry, collinear neighbours merged."""
    lines = [g for g in getattr(geometry, "geoms", [geometry])
             if isinstance(g, LineString) and not g.is_empty]
    if not lines:
        return []
    merged = shapely.line_merge(shapely.union_all(lines))
    pieces = []
    for line in getattr(merged, "geoms", [merged]):
        coords = list(line.coords)
        run = [coords[0]]
        for point in coords[1:]:
            # A bend ends a straight stretch: axis-aligned walls turn by 90 degrees.
            if len(run) >= 2 and not _collinear(run[-2], run[-1], point):
                pieces.append(LineString(run))
                run = [run[-1]]
            run.append(point)
        pieces.append(LineString(run))
    return [LineString([p.coords[0], p.coords[-1]]) for p in pieces]


def _collinear(a: tuple[float, ...], b: tuple[float, ...], c: tuple[float, ...]) -> bool:
    return abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) < 1e-9


def room_polygon(rects: Sequence[Box]) -> Polygon:
    """One counter-clockwise polygon from a room's rectangles.

    >>> room_polygon([Box(0, 0, 2, 1), Box(0, 1, 1, 2)]).area
    3.0
    """
    merged = shapely.set_precision(
        shapely.union_all([r.to_polygon() for r in rects], grid_size=GRID), GRID
    )
    if not isinstance(merged, Polygon):
        raise GeometryError(f"rectangles form a {merged.geom_type}, not one polygon")
    return shapely.orient_polygons(merged)


def polygon_coords(polygon: Polygon) -> list[tuple[float, float]]:
    """Exterior vertices without the repeated closing one, collinear ones removed."""
    simple = polygon.simplify(0)
    return [(float(x), float(y)) for x, y in list(simple.exterior.coords)[:-1]]


def snap_map(fixed: Iterable[float], loose: Iterable[float], tol: float) -> dict[float, float]:
    """Map each loose coordinate to the nearest fixed (domain) one within `tol`, else to the
    first of its run of loose coordinates spanning at most `tol`.

    >>> snap_map([5.0], [4.99991, 5.00008, 7.0, 7.00001, 7.00011], 1e-4)
    {4.99991: 5.0, 5.00008: 5.0, 7.0: 7.0, 7.00001: 7.0, 7.00011: 7.00011}
    """
    walls = sorted(set(fixed))
    mapping: dict[float, float] = {}
    anchor: float | None = None
    for value in sorted(set(loose)):
        k = bisect.bisect_left(walls, value)
        wall = min(walls[max(k - 1, 0):k + 1], key=lambda w: abs(w - value), default=None)
        if wall is not None and abs(wall - value) <= tol:
            mapping[value] = wall
            continue
        if anchor is None or value - anchor > tol:
            anchor = value
        mapping[value] = anchor
    return mapping


def snap_rooms(
    rooms: Mapping[str, Sequence[Box]], xs: Iterable[float], ys: Iterable[float], tol: float
) -> dict[str, list[Box]]:
    """Rooms with every coordinate within `tol` of a domain line (`xs`, `ys`) or of
    another room's coordinate moved onto one value, so shared walls are exactly shared.

    >>> snap_rooms({"a": [Box(0, 0, 2.0000001, 1)], "b": [Box(2, 0, 3, 1)]}, [0, 3], [0, 1], 1e-4)
    {'a': [Box(x0=0, y0=0, x1=2, y1=1)], 'b': [Box(x0=2, y0=0, x1=3, y1=1)]}
    """
    boxes = [b for rects in rooms.values() for b in rects]
    sx = snap_map(xs, [v for b in boxes for v in (b.x0, b.x1)], tol)
    sy = snap_map(ys, [v for b in boxes for v in (b.y0, b.y1)], tol)
    return {
        room_id: [Box(sx[b.x0], sy[b.y0], sx[b.x1], sy[b.y1]) for b in rects]
        for room_id, rects in rooms.items()
    }


def wall_runs(fixed: Iterable[float], walls: Iterable[tuple[float, float]], tol: float
              ) -> dict[float, float]:
    """Map each wall coordinate of `walls` ((coordinate, length) pairs) to one value per
    run of coordinates spanning at most `tol`: the fixed line within `tol` of the whole
    run when there is one, else the run's coordinate with the most wall on it (the wall
    the others line up with). A run near two fixed lines is left as it is.

    >>> wall_runs([0.0, 6.8], [(6.77, 2.0), (6.83, 3.8), (4.9, 1.0), (4.95, 4.0)], 0.1)
    {4.9: 4.95, 4.95: 4.95, 6.77: 6.8, 6.83: 6.8}
    """
    lines = sorted(set(fixed))
    length: dict[float, float] = {}
    for value, extent in walls:
        length[value] = length.get(value, 0.0) + extent
    runs: list[list[float]] = []
    for value in sorted(length):
        if runs and value - runs[-1][0] <= tol:
            runs[-1].append(value)
        else:
            runs.append([value])
    mapping: dict[float, float] = {}
    for run in runs:
        k = bisect.bisect_left(lines, run[-1] - tol)
        near = [w for w in lines[k:] if w <= run[0] + tol]
        if len(near) > 1:  # two walls of the outline this close: each keeps its own
            mapping.update({v: v for v in run})
            continue
        target = near[0] if near else max(run, key=lambda v: (length[v], -v))
        mapping.update(dict.fromkeys(run, target))
    return mapping


def wall_moves(
    rooms: Mapping[str, Sequence[Box]], xs: Iterable[float], ys: Iterable[float], tol: float
) -> list[tuple[int, dict[float, float]]]:
    """The runs of wall coordinates at most `tol` apart that `wall_runs` moves onto one
    line (the outline's `xs` and `ys` stay), each as (axis: 0 for x, 1 for y, the map of
    its coordinates), to be applied together or one at a time (`walls_moved`). All of
    them together keep the coordinates' order, so rooms that did not overlap still do
    not, and rooms that covered the floor still do."""
    boxes = [b for rects in rooms.values() for b in rects]
    moves: list[tuple[int, dict[float, float]]] = []
    for axis, fixed, walls in (
            (0, xs, [(v, b.depth) for b in boxes for v in (b.x0, b.x1)]),
            (1, ys, [(v, b.width) for b in boxes for v in (b.y0, b.y1)])):
        runs: dict[float, dict[float, float]] = {}
        for value, target in wall_runs(fixed, walls, tol).items():
            runs.setdefault(target, {})[value] = target
        moves += [(axis, run) for run in runs.values()
                  if any(value != target for value, target in run.items())]
    return moves


def walls_moved(rooms: Mapping[str, Sequence[Box]],
                moves: Iterable[tuple[int, dict[float, float]]]) -> dict[str, list[Box]]:
    """`rooms` with the wall coordinates of `moves` (`wall_moves`) moved, rectangles left
    without area dropped."""
    sx: dict[float, float] = {}
    sy: dict[float, float] = {}
    for axis, run in moves:
        (sx if axis == 0 else sy).update(run)
    moved = {room_id: [Box(sx.get(b.x0, b.x0), sy.get(b.y0, b.y0),
                           sx.get(b.x1, b.x1), sy.get(b.y1, b.y1)) for b in rects]
             for room_id, rects in rooms.items()}
    return {room_id: [b for b in rects if b.width > EPS and b.depth > EPS]
            for room_id, rects in moved.items()}


def domain_lines(problem: Problem) -> tuple[list[float], list[float]]:
    """The x and y coordinates of the outline's and the obstacles' walls."""
    xs = [x for x, _ in problem.boundary]
    ys = [y for _, y in problem.boundary]
    for o in problem.obstacles:
        xs += [o.x, o.x + o.width]
        ys += [o.y, o.y + o.depth]
    return xs, ys


def on_edge(b: Box, e: Edge) -> bool:
    """Whether one whole side of `b` lies on edge `e` (what Eq. 9 asks)."""
    lo, hi = e.span
    if e.horizontal:
        side = b.y0 if e.facing == "south" else b.y1
        return abs(side - e.line) <= 1e-6 and b.x0 >= lo - 1e-6 and b.x1 <= hi + 1e-6
    side = b.x0 if e.facing == "west" else b.x1
    return abs(side - e.line) <= 1e-6 and b.y0 >= lo - 1e-6 and b.y1 <= hi + 1e-6
