"""The walls of a floor, found from its room polygons: geometry only, for the writers
that build walls (IFC, the DXF drawing's ``A-WALL`` layer).

A wall is one straight run of boundary between the same spaces: the facade, where the
outline runs, 25 cm thick and outside the outline (the rooms keep their full area);
partitions, where rooms meet, 10 cm thick and centred on the line they share. Every run
is built once, however many rooms it bounds (no doubled walls). Facade walls meet at
the outline's corners without gap or overlap; partitions run on by half their thickness
at a free end so that two meeting at a corner close it.

Where a room meets an obstacle no wall is built: the obstacle (a column, a core) is an
element of its own. Where aisles meet each other there is no wall either: circulation
runs on.

>>> from shapely.geometry import box
>>> walls = wall_segments({"a": box(0, 0, 3, 4), "b": box(3, 0, 5, 4)}, box(0, 0, 5, 4))
>>> [(w.exterior, w.length, w.spaces) for w in walls if not w.exterior]
[(False, 4.0, ('a', 'b'))]
>>> sum(w.exterior for w in walls), round(sum(w.length for w in walls if w.exterior), 2)
(6, 19.0)
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.polygon import orient

from floorplan.solver.geometry import GRID
from floorplan.solver.openings import FACADE_THICKNESS

Coord = tuple[float, float]

#: Wall thicknesses, metres: a load-bearing facade and a light partition (as the SVG
#: plan draws them).
PARTITION_THICKNESS = 0.10
#: Two points closer than this (metres) are one; a point this near a line is on it.
TOLERANCE = 1e-4


@dataclass(frozen=True)
class WallSegment:
    """One straight wall. Its body lies beside the axis ``start -> end``: at left-hand
    distances from `offset` to ``offset + thickness`` (a facade, axis on the outline
    run counter-clockwise: from ``-thickness`` to 0, outside; a partition: centred)."""

    start: Coord
    end: Coord
    thickness: float
    offset: float
    exterior: bool
    spaces: tuple[str, ...]
    """The ids of the spaces (rooms, aisles) the wall bounds: one or two."""
    edge: tuple[Coord, Coord]
    """The boundary the wall stands on, before its ends were lengthened or shortened
    to meet the walls at its corners: where it touches its spaces."""

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    @property
    def direction(self) -> Coord:
        """The unit vector from `start` to `end`."""
        (x0, y0), (x1, y1) = self.start, self.end
        return (x1 - x0) / self.length, (y1 - y0) / self.length

    def footprint(self) -> Polygon:
        """The wall's body seen from above, counter-clockwise.

        >>> WallSegment((0, 0), (2, 0), 0.1, -0.05, False, ("a",), ((0, 0), (2, 0))
        ...             ).footprint().bounds
        (0.0, -0.05, 2.0, 0.05)
        """
        (x0, y0), (x1, y1) = self.start, self.end
        dx, dy = self.direction
        nx, ny = -dy, dx
        lo, hi = self.offset, self.offset + self.thickness
        return orient(Polygon([(x0 + nx * lo, y0 + ny * lo), (x1 + nx * lo, y1 + ny * lo),
                               (x1 + nx * hi, y1 + ny * hi), (x0 + nx * hi, y0 + ny * hi)]))

    def along(self, point: Coord) -> float:
        """How far along the axis from `start` the foot of `point` is, metres."""
        dx, dy = self.direction
        return (point[0] - self.start[0]) * dx + (point[1] - self.start[1]) * dy


def wall_segments(
    spaces: Mapping[str, Polygon], outline: Polygon, *,
    circulation: Collection[str] = (), obstacles: Sequence[Polygon] = (),
) -> list[WallSegment]:
    """The walls of a floor whose rooms and aisles are `spaces` (id -> polygon) inside
    `outline`: the whole facade, and a partition along every run of boundary between
    two spaces, or between a space and uncovered floor. `circulation` names the aisles
    (no wall between two of them); along `obstacles` no partition is built."""
    ring = orient(outline, sign=1.0).exterior
    lines = [ring, *(p.exterior for p in spaces.values())]
    noded = shapely.union_all(lines, grid_size=GRID)
    keys = list(spaces)
    boundaries = [spaces[k].exterior for k in keys]
    tree = shapely.STRtree(boundaries)
    blocked = shapely.union_all([o.exterior for o in obstacles]) if obstacles else None
    runs: dict[tuple[tuple[str, ...], bool], list[LineString]] = defaultdict(list)
    for part in shapely.get_parts(noded):
        coords = list(part.coords)
        for a, b in itertools.pairwise(coords):
            if math.dist(a, b) < TOLERANCE:
                continue
            mid = Point((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
            exterior = ring.distance(mid) < TOLERANCE
            near = tree.query(mid, predicate="dwithin", distance=TOLERANCE)
            touching = tuple(sorted(keys[k] for k in near))
            if not exterior:
                if not touching or all(k in circulation for k in touching):
                    continue
                if blocked is not None and blocked.distance(mid) < TOLERANCE:
                    continue
            runs[touching, exterior].append(LineString([a, b]))
    inside = Polygon(ring)
    walls = [_wall(run, touching, exterior, inside)
             for (touching, exterior), pieces in sorted(runs.items())
             for run in _straight_runs(pieces)]
    return sorted(walls, key=lambda w: (not w.exterior, w.spaces, w.edge))


def _straight_runs(pieces: list[LineString]) -> list[tuple[Coord, Coord]]:
    """Contiguous pieces joined, then cut where they turn: straight runs end to end."""
    merged = shapely.line_merge(shapely.MultiLineString(pieces))
    runs: list[tuple[Coord, Coord]] = []
    for line in shapely.get_parts(merged):
        coords = [tuple(c) for c in line.coords]
        start = coords[0]
        for k in range(1, len(coords) - 1):
            if not _collinear(start, coords[k], coords[k + 1]):
                runs.append((start, coords[k]))
                start = coords[k]
        runs.append((start, coords[-1]))
    return runs


def _collinear(a: Coord, b: Coord, c: Coord) -> bool:
    return abs((b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])) < TOLERANCE**2


def _wall(run: tuple[Coord, Coord], spaces: tuple[str, ...], exterior: bool,
          outline: Polygon) -> WallSegment:
    p, q = run
    ring = outline.exterior
    if not exterior:
        t = PARTITION_THICKNESS
        start = p if ring.distance(Point(p)) < TOLERANCE else _moved(p, q, -t / 2)
        end = q if ring.distance(Point(q)) < TOLERANCE else _moved(q, p, -t / 2)
        return WallSegment(start, end, t, -t / 2, False, spaces, (p, q))
    if not _on_the_left(p, q, outline):
        p, q = q, p  # the outline counter-clockwise: the building on the left
    t = FACADE_THICKNESS
    turn = _turn_at(q, p, ring)
    end = _moved(q, p, -t) if turn > 0 else _moved(q, p, t) if turn < 0 else q
    return WallSegment(p, end, t, -t, True, spaces, (p, q))


def _on_the_left(p: Coord, q: Coord, outline: Polygon) -> bool:
    """Whether `outline` lies on the left of the run ``p -> q`` along its boundary."""
    length = math.dist(p, q)
    step = min(0.01, length / 4)
    probe = Point((p[0] + q[0]) / 2 - (q[1] - p[1]) / length * step,
                  (p[1] + q[1]) / 2 + (q[0] - p[0]) / length * step)
    return bool(outline.contains(probe))


def _turn_at(q: Coord, p: Coord, ring: shapely.LinearRing) -> float:
    """Positive where the outline, arriving at `q` from `p`, turns left there (a
    convex corner: the facade runs on by its thickness), negative where it turns right
    (a reflex corner: it stops short by as much), 0 where it goes straight on or `q` is
    no corner."""
    coords = list(ring.coords)[:-1]
    for k, c in enumerate(coords):
        if math.dist(c, q) < TOLERANCE:
            nxt = coords[(k + 1) % len(coords)]
            cross = (q[0] - p[0]) * (nxt[1] - q[1]) - (q[1] - p[1]) * (nxt[0] - q[0])
            return cross / (math.dist(p, q) * math.dist(q, nxt))
    return 0.0


def _moved(point: Coord, towards: Coord, by: float) -> Coord:
    """`point` moved `by` metres towards `towards` (negative: away from it)."""
    length = math.dist(point, towards)
    return (point[0] + (towards[0] - point[0]) * by / length,
            point[1] + (towards[1] - point[1]) * by / length)


def walls_of(walls: Sequence[WallSegment], segments: Sequence[tuple[Coord, Coord]],
             ) -> list[WallSegment | None]:
    """For each of `segments` (doors', windows'), the wall whose edge holds it, else
    None.

    >>> from shapely.geometry import box
    >>> walls = wall_segments({"a": box(0, 0, 3, 4), "b": box(3, 0, 5, 4)}, box(0, 0, 5, 4))
    >>> [w and w.spaces for w in walls_of(walls, [((3, 1), (3, 2)), ((1, 1), (2, 1))])]
    [('a', 'b'), None]
    """
    edges = [LineString(w.edge) for w in walls]
    tree = shapely.STRtree(edges)
    found: list[WallSegment | None] = []
    for a, b in segments:
        ends = [Point(a), Point(b)]
        near = tree.query(LineString([a, b]), predicate="dwithin", distance=TOLERANCE)
        found.append(next((walls[k] for k in sorted(near)
                           if all(edges[k].distance(e) < TOLERANCE for e in ends)), None))
    return found
