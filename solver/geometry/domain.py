"""The domain (paper Sec. 5.3): the bounding box minus blocked rectangles, the outline's
edges with their compass facing, and the obstacles on the outline that a room may wrap
around (`Notch`)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import shapely
from shapely.geometry import LineString, MultiPolygon, Polygon
from shapely.geometry.base import BaseGeometry

from floorplan.models import Problem, Rect
from floorplan.solver.geometry.boxes import EPS, Box, encloses
from floorplan.solver.geometry.regions import rectangles_of

#: A room wrapping an obstacle keeps at least this much floor (metres) beside each side
#: of it away from the outline: a usable strip with walls of its own, never a wall
#: shared with the obstacle's that an adjacency could count as contact.
WRAP_MARGIN = 0.5

Facing = Literal["north", "south", "east", "west"]


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


#: Bearings of the plan's sides (north up) and of the compass words, degrees clockwise.
BEARINGS: dict[str, float] = {"north": 0.0, "east": 90.0, "south": 180.0, "west": 270.0}


def compass_words(edge: Edge, north: float) -> frozenset[str]:
    """The compass words an edge faces with true north `north` degrees clockwise from the
    plan's +y (`Problem.north`): the words within 45 degrees of its outward normal's
    bearing, two where it lies halfway between them.

    >>> e = boundary_edges([(0, 0), (4, 0), (4, 3), (0, 3)])[1]  # the plan's east side
    >>> sorted(compass_words(e, 0)), sorted(compass_words(e, 90)), sorted(compass_words(e, 45))
    (['east'], ['north'], ['east', 'north'])
    """
    bearing = (BEARINGS[edge.facing] - north) % 360.0
    return frozenset(word for word, b in BEARINGS.items()
                     if min((bearing - b) % 360.0, (b - bearing) % 360.0) <= 45.0 + 1e-9)


def edges_named(problem: Problem, edges: Sequence[Edge], names: Iterable[int | str]) -> list[Edge]:
    """The edges a room's `boundary` list names: indices, or every edge facing a compass
    word (true north as `problem.north` gives it)."""
    chosen: dict[int, Edge] = {}
    for name in names:
        for edge in edges:
            if edge.index == name or name in compass_words(edge, problem.north):
                chosen[edge.index] = edge
    return [chosen[k] for k in sorted(chosen)]


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

    >>> from shapely.geometry import box
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
