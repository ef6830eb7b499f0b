"""The walls two rooms share: their total length, the longest straight stretch (an
adjacency's contact, Eq. 10), and a linear geometry's straight pieces."""

from __future__ import annotations

import shapely
from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry

from floorplan.solver.geometry.boxes import EPS


def shared_wall_length(a: BaseGeometry, b: BaseGeometry) -> float:
    """Length in metres of the boundary two rooms share, all its stretches together
    (an adjacency's contact is one stretch: `longest_shared_wall`).

    >>> from shapely.geometry import box
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

    >>> from shapely.geometry import box
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
