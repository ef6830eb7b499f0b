"""How far people walk to an exit along the corridors, measured on the plan alone: the
corridor polygons rasterised, a shortest walk over the raster's cells (eight neighbours,
diagonal steps sqrt 2 long) from the cells at each exit, read at each room's door onto a
corridor. Shares no code with the network IP that planned the corridors."""

from __future__ import annotations

import heapq
import math
from collections.abc import Mapping, Sequence

import numpy as np
import shapely
from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry

#: Raster cell (metres): a tenth of the narrowest corridor accepted, fine enough that a
#: walk's error from cell centres stays under a step.
CELL = 0.15

XY = tuple[float, float]


def walk_field(
    corridors: BaseGeometry, exits: Sequence[XY], cell: float = CELL,
    reach: float | None = None,
) -> tuple[np.ndarray, tuple[float, float, float]]:
    """Walking distance (metres) from the nearest exit to every raster cell of
    `corridors` (inf off the corridors or unreached), and the raster's (x0, y0, cell).
    An exit farther than `reach` (one raster cell by default) from the corridors is not
    reached; within it, the walk starts with the straight way onto them."""
    reach = cell if reach is None else reach
    x0, y0, x1, y1 = corridors.bounds
    nx, ny = max(1, math.ceil((x1 - x0) / cell)), max(1, math.ceil((y1 - y0) / cell))
    xs = x0 + (np.arange(nx) + 0.5) * cell
    ys = y0 + (np.arange(ny) + 0.5) * cell
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    shapely.prepare(corridors)
    inside = shapely.contains_xy(corridors, gx, gy)
    dist = np.full((nx, ny), np.inf)
    queue: list[tuple[float, int, int]] = []
    for ex, ey in exits:
        if corridors.distance(Point(ex, ey)) > reach:
            continue  # no corridor reaches this exit
        i, j = _nearest_inside(inside, x0, y0, cell, (ex, ey))
        if i is None:
            continue
        start = math.dist((ex, ey), (xs[i], ys[j]))
        if start < dist[i, j]:
            dist[i, j] = start
            heapq.heappush(queue, (start, i, j))
    steps = [
        (di, dj, cell * math.hypot(di, dj)) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj
    ]
    while queue:
        d, i, j = heapq.heappop(queue)
        if d > dist[i, j]:
            continue
        for di, dj, length in steps:
            a, b = i + di, j + dj
            if not (0 <= a < nx and 0 <= b < ny) or not inside[a, b]:
                continue
            # A diagonal step may not cut a corner of the corridor floor.
            if di and dj and not (inside[i + di, j] and inside[i, j + dj]):
                continue
            if d + length < dist[a, b]:
                dist[a, b] = d + length
                heapq.heappush(queue, (d + length, a, b))
    return dist, (x0, y0, cell)


def _nearest_inside(
    inside: np.ndarray, x0: float, y0: float, cell: float, point: XY
) -> tuple[int, int] | tuple[None, None]:
    cells = np.argwhere(inside)
    if not len(cells):
        return None, None
    centres = np.column_stack([x0 + (cells[:, 0] + 0.5) * cell, y0 + (cells[:, 1] + 0.5) * cell])
    k = int(np.argmin(np.hypot(centres[:, 0] - point[0], centres[:, 1] - point[1])))
    return int(cells[k, 0]), int(cells[k, 1])


def door_travel(
    corridors: BaseGeometry, exits: Sequence[XY], doors: Mapping[str, Sequence[tuple[XY, XY]]]
) -> dict[str, float]:
    """Per room, the shortest walk from the middle of one of its doors onto a corridor
    to the nearest exit (rooms whose doors reach no exit get inf)."""
    dist, (x0, y0, cell) = walk_field(corridors, exits)
    inside = np.isfinite(dist)
    out: dict[str, float] = {}
    for room, segments in doors.items():
        best = math.inf
        for a, b in segments:
            mid = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
            i, j = _nearest_inside(inside | (dist < np.inf), x0, y0, cell, mid)
            if i is not None:
                best = min(
                    best,
                    float(dist[i, j])
                    + math.dist(mid, (x0 + (i + 0.5) * cell, y0 + (j + 0.5) * cell)),
                )
        out[room] = best
    return out


def route_walk(corridors: BaseGeometry, a: XY, b: XY) -> float:
    """The walk from `a` to `b` along `corridors`: straight onto the corridor floor
    nearest each point, along it between (inf when no corridor joins them)."""
    if corridors.is_empty:
        return math.inf
    dist, (x0, y0, cell) = walk_field(corridors, [a], reach=math.inf)
    i, j = _nearest_inside(np.isfinite(dist), x0, y0, cell, b)
    if i is None:
        return math.inf
    return float(dist[i, j]) + math.dist(b, (x0 + (i + 0.5) * cell, y0 + (j + 0.5) * cell))
