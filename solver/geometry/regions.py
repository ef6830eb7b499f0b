"""Rectilinear regions as rectangles: a region split into few disjoint ones
(`rectangles_of`), the largest around a point, the space too narrow for a room
(`unusable_space`), and a room's rectangles as one polygon (`room_polygon`)."""

from __future__ import annotations

import bisect
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from floorplan.solver.geometry.boxes import EPS, GRID, Box, GeometryError


def rectangles_of(region: BaseGeometry) -> list[Box]:
    """Split a rectilinear region into few disjoint rectangles (maximal horizontal strips
    merged vertically when they line up).

    >>> from shapely.geometry import box
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

    >>> from shapely.geometry import box
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
