"""Large layouts, step 1: which rooms form a region (the user's, or a balanced
partition), and the regions as the rooms of a first problem."""

from __future__ import annotations

import math
import statistics
from collections import deque
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon

from floorplan.models import (
    Adjacency,
    Problem,
    Region,
    Room,
)

#: Rooms per region the automatic partition aims for (the paper's Fig. 8 blocks).
REGION_ROOMS = 14
#: What a band plan pays, in estimated E_size per room (m²), for having all its rows
#: off the aisles (in proportion for a share of them): without a price the fewest
#: aisles would always win, rooms being largest there.
ACCESS_PRICE = 1.0
#: Planned bands (automatic regions) thinner than this share of a row are not kept.
THINNEST_BAND = 0.75
#: Name of the region that gathers the rooms no explicit region names.
REST_REGION = "rest"
#: Guide points closer than this (metres) go to one region: an aisle between them
#: would leave one of them in the aisle.
NEAR_POINTS = 8.0
#: How much fuller than the mean a region may get to keep rooms of one facade together.
BALANCE_SLACK = 1.15


def regions_apply(problem: Problem) -> bool:
    """Regions are used when the problem names them, or has more rooms than
    `options.regions_above` (0: never), entrance or not: a floor that large needs
    walking space to reach its rooms. Without an entrance the aisles form one network
    touching every region and the facade (its ends are the exits)."""
    return problem.by_regions


def room_adjacency(problem: Problem) -> list[Adjacency]:
    """The adjacencies between rooms (those naming regions are the regions' own)."""
    room_ids = {r.id for r in problem.rooms}
    return [a for a in problem.adjacency if a.a in room_ids]


def rooms_only(problem: Problem) -> Problem:
    """The problem as a flat one: no regions, no region adjacencies, no partition."""
    options = problem.options.model_copy(update={"regions_above": 0})
    return problem.model_copy(update={"regions": None, "adjacency": room_adjacency(problem),
                                      "options": options})


def partition(problem: Problem) -> list[Region]:
    """The problem's regions, plus one of the rooms in none; else the automatic ones."""
    if problem.regions is None:
        return auto_partition(problem)
    named = {room_id for region in problem.regions for room_id in region.rooms}
    rest = [r.id for r in problem.rooms if r.id not in named]
    return [*problem.regions, *([Region(id=_free_id(problem, REST_REGION), rooms=rest)]
                                if rest else [])]


def auto_partition(problem: Problem) -> list[Region]:
    """Balanced regions of about `REGION_ROOMS` rooms. Rooms joined by adjacencies stay
    together (one unit); units with guide points go first, one per region while regions
    without one are left (a region then covers one place, not two far apart); the other
    units, largest first, go to the region with the least area, preferring one whose
    rooms ask for the same exterior walls unless it is already `BALANCE_SLACK` above the
    mean."""
    rooms = problem.rooms
    count = max(2, round(len(rooms) / REGION_ROOMS))
    typical = typical_area(problem)
    units = room_units(problem)
    area = {id(u): sum(room_area(r, typical) for r in u) for u in units}
    mean = sum(area.values()) / count
    bins: list[list[Room]] = [[] for _ in range(count)]
    load = [0.0] * count
    points: list[list[tuple[float, float]]] = [[] for _ in range(count)]
    pinned = [u for u in units if any(r.positions for r in u)]
    for unit in sorted(pinned, key=lambda u: _first_point(u)):
        unit_points = [p for r in unit for p in r.positions]
        empty = [k for k in range(count) if not points[k]]
        near = [k for k in range(count) if points[k] and len(points[k]) < 2 and min(
            math.dist(p, q) for p in points[k] for q in unit_points) <= NEAR_POINTS]
        if near:
            k = near[0]
        elif empty:
            k = min(empty, key=lambda k: load[k])
        else:
            k = min(range(count), key=lambda k: min(math.dist(p, q) for p in points[k]
                                                       for q in unit_points))
        bins[k] += unit
        load[k] += area[id(unit)]
        points[k] += unit_points
    for unit in sorted((u for u in units if u not in pinned), key=lambda u: -area[id(u)]):
        key = _facade_key(unit)
        same = [k for k in range(count) if bins[k] and _facade_key(bins[k]) == key
                and load[k] + area[id(unit)] <= mean * BALANCE_SLACK]
        k = min(same or range(count), key=lambda k: load[k])
        bins[k] += unit
        load[k] += area[id(unit)]
    return [Region(id=_free_id(problem, f"region-{k + 1}"), rooms=[r.id for r in rooms_k])
            for k, rooms_k in enumerate(bins) if rooms_k]


def room_units(problem: Problem) -> list[list[Room]]:
    """Rooms grouped by the adjacencies joining them (connected components)."""
    links: dict[str, set[str]] = {r.id: set() for r in problem.rooms}
    for adj in room_adjacency(problem):
        for partner in adj.partners:
            links[adj.a].add(partner)
            links[partner].add(adj.a)
    seen: set[str] = set()
    units = []
    for room in problem.rooms:
        if room.id in seen:
            continue
        queue, unit = deque([room.id]), []
        seen.add(room.id)
        while queue:
            here = queue.popleft()
            unit.append(problem.room(here))
            for there in sorted(links[here] - seen):
                seen.add(there)
                queue.append(there)
        units.append(unit)
    return units


def _first_point(unit: Sequence[Room]) -> tuple[float, float]:
    return min(p for r in unit for p in r.positions)


def _facade_key(rooms: Sequence[Room]) -> tuple[str, ...]:
    return tuple(sorted({str(b) for r in rooms for b in r.boundary}))


def _free_id(problem: Problem, wanted: str) -> str:
    taken = {r.id for r in problem.rooms} | {g.id for g in problem.regions or []}
    name, k = wanted, 1
    while name in taken:
        k += 1
        name = f"{wanted}-{k}"
    return name


def typical_area(problem: Problem) -> float:
    """A room's share of the free floor: the area of a room without sizes."""
    return float(problem.free_area().area) / len(problem.rooms)


def room_area(room: Room, typical: float) -> float:
    """The area a room asks for: its target, else the middle of its bounds."""
    if room.target_size is not None:
        return room.target_size[0] * room.target_size[1]
    if room.min_size is not None and room.max_size is not None:
        return math.prod((lo + hi) / 2 for lo, hi in zip(room.min_size, room.max_size,
                                                           strict=True))
    if room.min_size is not None:
        return max(typical, room.min_size[0] * room.min_size[1])
    return typical


def free_rectangles(free: Polygon) -> list[tuple[float, float]]:
    """[width, depth] of the rectangles the free floor holds, spanned by its vertex
    coordinates: for every run of grid columns, each run of rows inside all of them."""
    coords = shapely.get_coordinates(shapely.boundary(free))
    xs = sorted({round(float(c), 9) for c in coords[:, 0]})
    ys = sorted({round(float(c), 9) for c in coords[:, 1]})
    if len(xs) < 2 or len(ys) < 2:
        return []
    cx = (np.array(xs[:-1]) + np.array(xs[1:])) / 2
    cy = (np.array(ys[:-1]) + np.array(ys[1:])) / 2
    grid_x, grid_y = np.meshgrid(cx, cy)
    shapely.prepare(free)
    cells = shapely.contains_xy(free, grid_x, grid_y)  # rows by y, columns by x
    found: set[tuple[float, float]] = set()
    for first in range(len(xs) - 1):
        inside = np.ones(len(ys) - 1, dtype=bool)
        for last in range(first, len(xs) - 1):
            inside &= cells[:, last]
            if not inside.any():
                break
            start = None
            for j, cell in enumerate([*inside, False]):
                if cell and start is None:
                    start = j
                elif not cell and start is not None:
                    found.add((xs[last + 1] - xs[first], ys[j] - ys[start]))
                    start = None
    return sorted(found)


def fitting_target(target: tuple[float, float], least: tuple[float, float],
                   holes: Sequence[tuple[float, float]]) -> tuple[float, float]:
    """A planned region target (`region_problem`) the free floor can hold as one
    rectangle: a target that fits nowhere reads, to level 1, as a room its plan drew as
    an L (`unfitting_targets`), which then starts as two rectangles and loses the rows
    of slicing; a planned bar is only a guess at a shape (four bars beside a central
    core fit nowhere, and a region layout then took more than its time). The bar keeps
    its area and takes the depth nearest its own (and at least `least`) that a free
    rectangle holding that area allows; unchanged when it fits, or when no free
    rectangle holds its area (that region is an L)."""
    width, depth = target
    if any(w >= width - 1e-9 and d >= depth - 1e-9 for w, d in holes):
        return target
    area = width * depth
    best: tuple[float, tuple[float, float]] | None = None
    for w, d in holes:
        lo, hi = max(area / w, least[1]), min(d, area / least[0])
        if lo > hi + 1e-9:
            continue
        deep = min(max(depth, lo), hi)
        change = abs(math.log(deep / depth))
        if best is None or change < best[0]:
            best = (change, (area / deep, deep))
    return target if best is None else best[1]


def region_problem(problem: Problem, regions: Sequence[Region], time_limit: float) -> Problem:
    """Regions as the rooms of a first problem. A region's area is its rooms' share of
    the free floor (their target areas, scaled so that all regions fill it: the aisles
    come out of every region in proportion); without a target of its own it is a bar
    two rooms deep plus an aisle, so that each of its rooms can face an aisle, reshaped
    to one the free floor can hold where it can hold none (`fitting_target`). Without a
    minimum of its own, it may shrink from its target as far as its rooms may from
    theirs (by area: the sum of their minimums over the sum of their targets, each side
    by the root), and at least to a room's minimum plus an aisle: a region only bound by
    the latter came out a quarter of its share (office-regions: 5 x 7 m for six offices
    of 3.5 x 3.1 m) and, padded with a strip of floor the aisle then took, could not hold
    its rooms. It covers its own points (else its rooms' points, at most two) and
    touches its own exterior walls (else those its rooms ask for)."""
    typical = typical_area(problem)
    holes = free_rectangles(problem.free_area())
    wanted = {g.id: sum(room_area(problem.room(r), typical) for r in g.rooms) for g in regions}
    scale = float(problem.free_area().area) / sum(wanted.values())
    rooms = []
    for g in regions:
        members = [problem.room(r) for r in g.rooms]
        depths = [(r.target_size or r.min_size or (math.sqrt(typical),) * 2)[1] for r in members]
        area = wanted[g.id] * scale
        least = tuple(max((r.min_size or (0.0, 0.0))[k] for r in members) + problem.aisle_width
                      for k in (0, 1))
        target = g.target_size
        if target is None:
            deep = min(2 * statistics.median(depths) + problem.aisle_width, math.sqrt(area))
            target = fitting_target((max(area / deep, least[0]), max(deep, least[1])),
                                    least, holes)
        points = list(g.positions) or [p for r in members for p in r.positions]
        if len(points) > 2:
            points = list(max(((p, q) for p in points for q in points),
                              key=lambda pq: math.dist(*pq)))
        shrink = math.sqrt(sum(math.prod(r.min_size or (0.0, 0.0)) for r in members)
                           / sum(room_area(r, typical) for r in members))
        lowest = tuple(min(max(least[k], target[k] * shrink), target[k]) for k in (0, 1))
        rooms.append(Room(
            id=g.id, type="region", target_size=target, max_size=g.max_size,
            min_size=g.min_size or lowest,
            aspect_ratio=g.aspect_ratio, positions=points,
            boundary=g.boundary or sorted({b for r in members for b in r.boundary}, key=str),
        ))
    region_ids = {g.id for g in regions}
    adjacency = [a for a in problem.adjacency if a.a in region_ids]
    options = problem.options.model_copy(update={
        "time_limit": time_limit, "regions_above": 0, "require_connected": False})
    return Problem(name=f"{problem.name} regions", boundary=problem.boundary,
                   obstacles=problem.obstacles, rooms=rooms, adjacency=adjacency,
                   weights=problem.weights, options=options, north=problem.north)
