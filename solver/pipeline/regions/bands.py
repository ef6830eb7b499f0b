"""Large layouts, step 1 above `options.regions_above` rooms: bars of rooms planned across
the floor along the aisles."""

from __future__ import annotations

import itertools
import math
import statistics
from collections.abc import Sequence

import shapely
from shapely.geometry import Polygon

from floorplan.models import (
    Problem,
)
from floorplan.solver.pipeline.regions.partition import (
    ACCESS_PRICE,
    REGION_ROOMS,
    THINNEST_BAND,
    room_area,
    typical_area,
)
from floorplan.solver.pipeline.regions.parts import polygon_pieces


def band_regions(problem: Problem) -> dict[str, Polygon] | None:
    """Regions of an automatic partition, planned rather than solved for: the floor cut
    across its depth (y) into bands, two rows of rooms deep (a facade band may be one),
    whose shared walls become aisles (the facade bands lose half an aisle, the others a
    whole one). The number of aisles and the facade bands' depth are chosen by `_walls`;
    each band is cut along x into regions of about `REGION_ROOMS` rooms (walls between
    them become aisles only where the network needs them: `aisles._without_end_strips`).
    None when not even one aisle fits."""
    free = problem.free_area()
    x0, y0, x1, y1 = free.bounds
    walls = _walls(problem, y0, y1)
    if not walls:
        return None
    typical_room = sum(room_area(r, typical_area(problem)) for r in problem.rooms) / len(
        problem.rooms)
    shapes: dict[str, Polygon] = {}
    for lo, hi in itertools.pairwise([y0, *walls, y1]):
        band = free.intersection(shapely.box(x0, lo, x1, hi))
        for piece in polygon_pieces(band):
            count = max(1, round(piece.area / typical_room / REGION_ROOMS))
            px0, _, px1, _ = piece.bounds
            cuts = _cuts(problem, px0, px1, lo, hi, count)
            for left, right in itertools.pairwise(cuts):
                cut = piece.intersection(shapely.box(left, lo, right, hi))
                for part in polygon_pieces(cut):
                    if part.area > 1e-3:
                        shapes[f"region-{len(shapes) + 1}"] = part
    return shapes or None


def _cuts(problem: Problem, x0: float, x1: float, lo: float, hi: float,
          count: int) -> list[float]:
    """Where a band from `x0` to `x1` (between `lo` and `hi`) is cut into `count`
    regions: evenly, except that the sides of an obstacle standing in the band are cuts
    too and an even cut near one (within two aisle widths) moves onto it, so that the
    regions beside an atrium are rectangles rather than rings around it."""
    sides = sorted({x for o in problem.obstacles
                    if o.y < hi - 1e-6 and o.y + o.depth > lo + 1e-6
                    for x in (o.x, o.x + o.width) if x0 + 1e-6 < x < x1 - 1e-6})
    near = 2 * problem.aisle_width
    cuts = set(sides)
    for j in range(1, count):
        even = x0 + j * (x1 - x0) / count
        closest = min(sides, key=lambda x: abs(x - even), default=None)
        if closest is None or abs(closest - even) > near:
            cuts.add(even)
    return [x0, *sorted(cuts), x1]


def _walls(problem: Problem, y0: float, y1: float) -> list[float]:
    """The lines between bands, bottom to top, where the aisles run. Plans: n aisles
    evenly spaced, bands two rows deep, each facade band one or two rows deep (one:
    every row on an aisle), a line whose aisle would cut an atrium moved to its nearer
    side (`_clear_of_obstacles`) and one then leaving less than `THINNEST_BAND` of a
    row between aisles dropped. Each plan is judged as laid out (`_plan_score`): the
    one of least estimated size error per room plus `ACCESS_PRICE` times its share of
    rows off the aisles wins."""
    a = problem.aisle_width
    plans: list[tuple[float, float, list[float]]] = []  # error, rows off aisles, walls
    for n in range(1, int((y1 - y0) // a) + 1):
        for bottom, top in ((2, 2), (1, 2), (1, 1)):
            row = (y1 - y0 - n * a) / (2 * (n - 1) + bottom + top)
            if row <= a:
                continue
            walls: list[float] = []
            for wall in sorted(_clear_of_obstacles(problem, y0 + bottom * row + 2 * row * k
                                                   + a * k + a / 2) for k in range(n)):
                below = wall - a / 2 - (walls[-1] + a / 2 if walls else y0)
                if min(below, y1 - wall - a / 2) >= THINNEST_BAND * row:
                    walls.append(wall)
            if walls:
                plans.append((*_plan_score(problem, walls, y0, y1), walls))
    if not plans:
        return []
    return min(plans, key=lambda p: p[0] + ACCESS_PRICE * p[1])[2]


def _plan_score(problem: Problem, walls: Sequence[float], y0: float,
                y1: float) -> tuple[float, float]:
    """A band plan's estimated mean E_size per room (Eq. 6) and share of rows off the
    aisles. Each band holds the whole number of rows whose depth comes closest to the
    median target depth; the rooms share the floor the aisles leave evenly, so a room
    is as deep as its row and as wide as its share of that floor then allows."""
    free = problem.free_area()
    x0, _, x1, _ = free.bounds
    a = problem.aisle_width
    share = float(free.area) / ((x1 - x0) * (y1 - y0))
    typical = typical_area(problem)
    wanted = sum(room_area(r, typical) for r in problem.rooms)
    left = float(free.area) - len(walls) * a * (x1 - x0) * share
    sides = [r.target_size or (math.sqrt(typical),) * 2 for r in problem.rooms]
    width = statistics.median(w for w, _ in sides)
    depth = statistics.median(d for _, d in sides)
    edges = [y0, *walls, y1]
    error = off = total = 0.0
    for k, (lo, hi) in enumerate(itertools.pairwise(edges)):
        on_aisles = (k > 0) + (k < len(walls))
        height = hi - lo - a / 2 * on_aisles
        rows = min(range(1, 9), key=lambda r: abs(height / r / depth - 1))
        deep = height / rows / depth
        wide = (left / wanted) / deep
        error += height * ((width * (wide - 1)) ** 2 + (depth * (deep - 1)) ** 2)
        off += height * max(0, rows - on_aisles) / rows
        total += height
    return error / total, off / total


def _clear_of_obstacles(problem: Problem, wall: float) -> float:
    """`wall` moved, when its aisle would cut through an obstacle off the facade (an
    atrium), to the nearer of the obstacle's sides, the aisle then running along it:
    the bands keep whole rows beside the obstacle instead of rows cut by it."""
    half = problem.aisle_width / 2
    outline = problem.outline()
    for obstacle in problem.obstacles:
        box = obstacle.to_box()
        lo, hi = box.bounds[1], box.bounds[3]
        touches_facade = box.exterior.intersection(outline.exterior).length > 1e-6
        if touches_facade or not (lo < wall + half and wall - half < hi):
            continue
        wall = min((lo - half, hi + half), key=lambda y: abs(y - wall))
    return wall
