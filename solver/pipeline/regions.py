"""Large layouts through regions and aisles (paper Sec. 5.3, end; Fig. 8).

1. The rooms are grouped into regions: the problem's own (`Problem.regions`, rooms in
   none forming one more region), or, above `options.regions_above` rooms, bars of
   rooms planned across the floor along the aisles (`band_regions`; where not even one
   aisle fits, a balanced partition, `auto_partition`).
2. The user's regions are laid out as rooms of a first problem (`region_problem`) by
   the ordinary `solve`: each gets its rooms' share of the floor, aisles included.
3. The walls regions share are widened into aisles of `aisle_width`, joined into one
   network reaching the entrance (`solver/pipeline/aisles.py`).
4. The rooms of each region are laid out in what is left of it, one ordinary problem
   per region part (`room_problem`), solved by `solve` with a share of the time.
5. The whole is merged, given doors (every room onto an aisle where it touches one,
   else onto a neighbour that leads to one), windows, and checked independently.
"""

from __future__ import annotations

import itertools
import math
import statistics
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import shapely
from shapely.geometry import LineString, Point, Polygon

from models import (
    OUTSIDE,
    Adjacency,
    Aisle,
    Circulation,
    ConstraintCheck,
    Door,
    Layout,
    Problem,
    Region,
    Report,
    Room,
    RoomLayout,
    Termination,
)
from solver.geometry import (
    Box,
    boundary_edges,
    edges_named,
    polygon_coords,
    rectangles_of,
    room_polygon,
)
from solver.heuristics.slicing import slicing_has_demands
from solver.openings import door_segment as _door_segment
from solver.openings import (
    front_door,
    longest_shared_wall,
    may_connect,
    place_windows,
    requested_doors,
)
from solver.pipeline.aisles import AisleNetwork, aisle_network, aisle_pieces
from solver.verify.checker import SOFT_KINDS, check_aisles, check_layout

#: Rooms per region the automatic partition aims for (the paper's Fig. 8 blocks).
REGION_ROOMS = 14
#: Share of the time limit the region layout may use ...
REGION_SHARE = 0.2
#: ... and at most this many seconds per region: slicing lays the regions out at once
#: and the search after it rarely improves on that (measured: 0 of 8 steps on office-154).
REGION_SECONDS_PER_REGION = 0.25
#: The least time (s) a room sub-problem is given ...
MIN_PART_SECONDS = 0.15
#: ... and, when its rooms ask for sizes and guide points only, at most this many
#: seconds per room on top: slicing lays a part's rows out in a fraction of a second,
#: and the search after it found nothing better on office-154 or mall-140.
PART_SECONDS_PER_ROOM = 0.01
#: What a band plan pays, in estimated E_size per room (m²), for having all its rows
#: off the aisles (in proportion for a share of them): without a price the fewest
#: aisles would always win, rooms being largest there.
ACCESS_PRICE = 1.0
#: Planned bands (automatic regions) thinner than this share of a row are not kept.
THINNEST_BAND = 0.75
#: Rounds of dealing an automatic partition's rooms again when a part cannot hold them.
DEAL_ROUNDS = 3
#: Time kept per room for merging, doors and the check.
FINISH_SECONDS_PER_ROOM = 0.01
#: What a room sub-problem gives up, in turn, when it finds no layout (model fields
#: set to None; `positions` and `boundary` become empty).
RELAXATIONS: tuple[tuple[str, ...], ...] = (("aspect_ratio",), ("min_size",))
#: Name of the region that gathers the rooms no explicit region names.
REST_REGION = "rest"
#: Guide points closer than this (metres) go to one region: an aisle between them
#: would leave one of them in the aisle.
NEAR_POINTS = 8.0
#: How much fuller than the mean a region may get to keep rooms of one facade together.
BALANCE_SLACK = 1.15

EventSink = Callable[..., None]


def regions_apply(problem: Problem) -> bool:
    """Regions are used when the problem names them, or has more rooms than
    `options.regions_above` (0: never), entrance or not: a floor that large needs
    walking space to reach its rooms. Without an entrance the aisles form one network
    touching every region and the facade (its ends are the exits)."""
    above = problem.options.regions_above
    return problem.regions is not None or (above > 0 and len(problem.rooms) > above)


def room_adjacency(problem: Problem) -> list[Adjacency]:
    """The adjacencies between rooms (those naming regions are the regions' own)."""
    room_ids = {r.id for r in problem.rooms}
    return [a for a in problem.adjacency if a.a in room_ids]


def rooms_only(problem: Problem) -> Problem:
    """The problem as a flat one: no regions, no region adjacencies, no partition."""
    options = problem.options.model_copy(update={"regions_above": 0})
    return problem.model_copy(update={"regions": None, "adjacency": room_adjacency(problem),
                                      "options": options})


# 1. Regions.


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
    typical = _typical_area(problem)
    units = _units(problem)
    area = {id(u): sum(_room_area(r, typical) for r in u) for u in units}
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


def _units(problem: Problem) -> list[list[Room]]:
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


def _typical_area(problem: Problem) -> float:
    """A room's share of the free floor: the area of a room without sizes."""
    return float(problem.free_area().area) / len(problem.rooms)


def _room_area(room: Room, typical: float) -> float:
    """The area a room asks for: its target, else the middle of its bounds."""
    if room.target_size is not None:
        return room.target_size[0] * room.target_size[1]
    if room.min_size is not None and room.max_size is not None:
        return math.prod((lo + hi) / 2 for lo, hi in zip(room.min_size, room.max_size,
                                                           strict=True))
    if room.min_size is not None:
        return max(typical, room.min_size[0] * room.min_size[1])
    return typical


# 2. The region layout.


def region_problem(problem: Problem, regions: Sequence[Region], time_limit: float) -> Problem:
    """Regions as the rooms of a first problem. A region's area is its rooms' share of
    the free floor (their target areas, scaled so that all regions fill it: the aisles
    come out of every region in proportion); without a target of its own it is a bar
    two rooms deep plus an aisle, so that each of its rooms can face an aisle. It covers
    its own points (else its rooms' points, at most two) and touches its own exterior
    walls (else those its rooms ask for)."""
    typical = _typical_area(problem)
    wanted = {g.id: sum(_room_area(problem.room(r), typical) for r in g.rooms) for g in regions}
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
            target = (max(area / deep, least[0]), max(deep, least[1]))
        points = list(g.positions) or [p for r in members for p in r.positions]
        if len(points) > 2:
            points = list(max(((p, q) for p in points for q in points),
                              key=lambda pq: math.dist(*pq)))
        rooms.append(Room(
            id=g.id, type="region", target_size=target, max_size=g.max_size,
            min_size=g.min_size or (min(least[0], target[0]), min(least[1], target[1])),
            aspect_ratio=g.aspect_ratio, positions=points,
            boundary=g.boundary or sorted({b for r in members for b in r.boundary}, key=str),
        ))
    region_ids = {g.id for g in regions}
    adjacency = [a for a in problem.adjacency if a.a in region_ids]
    options = problem.options.model_copy(update={
        "time_limit": time_limit, "regions_above": 0, "require_connected": False})
    return Problem(name=f"{problem.name} regions", boundary=problem.boundary,
                   obstacles=problem.obstacles, rooms=rooms, adjacency=adjacency,
                   weights=problem.weights, options=options)


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
    typical_room = sum(_room_area(r, _typical_area(problem)) for r in problem.rooms) / len(
        problem.rooms)
    shapes: dict[str, Polygon] = {}
    for lo, hi in itertools.pairwise([y0, *walls, y1]):
        band = free.intersection(shapely.box(x0, lo, x1, hi))
        for piece in _pieces(band):
            count = max(1, round(piece.area / typical_room / REGION_ROOMS))
            px0, _, px1, _ = piece.bounds
            cuts = _cuts(problem, px0, px1, lo, hi, count)
            for left, right in itertools.pairwise(cuts):
                cut = piece.intersection(shapely.box(left, lo, right, hi))
                for part in _pieces(cut):
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
    typical = _typical_area(problem)
    wanted = sum(_room_area(r, typical) for r in problem.rooms)
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


def _pieces(geometry: object) -> list[Polygon]:
    return [g for g in getattr(geometry, "geoms", [geometry])
            if isinstance(g, Polygon) and not g.is_empty]


# 4. Rooms inside a region.


def room_problem(problem: Problem, part: Polygon, rooms: Sequence[Room],
                 time_limit: float) -> Problem:
    """The rooms of one region part as an ordinary problem on the part's outline:
    boundary demands move to the part's edges lying on the named exterior walls (a
    demand no such edge can meet is left to the final check), guide points stay."""
    outline = [(round(x, 6), round(y, 6)) for x, y in polygon_coords(part)]
    sub_edges = boundary_edges(outline)
    building = boundary_edges(problem.boundary)
    inside = part.buffer(1e-6, join_style="mitre")
    ids = {r.id for r in rooms}
    mapped = []
    for room in rooms:
        named = edges_named(problem, building, room.boundary)
        edges = sorted({e.index for e in sub_edges for b in named if _on_edge(e, b)})
        mapped.append(room.model_copy(update={
            "boundary": edges,
            "positions": [p for p in room.positions if inside.contains(Point(p))],
        }))
    adjacency = []
    for adj in room_adjacency(problem):
        partners = [p for p in adj.partners if p in ids]
        if adj.a in ids and partners:
            adjacency.append(adj if adj.b is not None else adj.model_copy(
                update={"any_of": partners}))
    holes = [b for hole in part.interiors for b in rectangles_of(Polygon(hole))]
    options = problem.options.model_copy(update={
        "time_limit": time_limit, "regions_above": 0, "require_connected": False})
    return Problem.model_validate({
        "name": problem.name, "boundary": outline,
        "obstacles": [{"x": b.x0, "y": b.y0, "width": b.width, "depth": b.depth,
                       "label": "aisle"} for b in holes],
        "rooms": [r.model_dump() for r in mapped],
        "adjacency": [a.model_dump(exclude_none=True) for a in adjacency],
        "weights": problem.weights.model_dump(), "options": options.model_dump(),
        "openings": problem.openings.model_dump(),
    })


def _on_edge(sub: object, building: object) -> bool:
    """A part's edge lies along a building edge: same line, same facing, overlapping."""
    from solver.geometry import Edge

    assert isinstance(sub, Edge) and isinstance(building, Edge)
    if sub.facing != building.facing or abs(sub.line - building.line) > 1e-6:
        return False
    lo, hi = sub.span
    blo, bhi = building.span
    return min(hi, bhi) - max(lo, blo) > 1e-6


def assign_to_parts(problem: Problem, rooms: Sequence[Room],
                    parts: Sequence[Polygon]) -> list[list[Room]]:
    """Share out `rooms` among region parts in proportion to their area: units of rooms
    joined by adjacencies stay together; units with a guide point go to the part holding
    it (else the nearest), then the others, largest first, to the part with the most area
    left, among those touching an exterior wall the unit asks for when there are any."""
    if len(parts) <= 1:
        return [list(rooms)] if parts else []
    typical = _typical_area(problem)
    ids = {r.id for r in rooms}
    sub = problem.model_copy(update={"rooms": list(rooms), "adjacency": [
        a for a in room_adjacency(problem) if a.a in ids and set(a.partners) <= ids]})
    units = _units(sub)
    total = sum(_room_area(r, typical) for r in rooms)
    room_share = total / sum(p.area for p in parts)
    free = [p.area * room_share for p in parts]
    out: list[list[Room]] = [[] for _ in parts]
    edges = boundary_edges(problem.boundary)

    def area_of(unit: Sequence[Room]) -> float:
        return sum(_room_area(r, typical) for r in unit)

    pinned = [u for u in units if any(r.positions for r in u)]
    for unit in sorted(pinned, key=area_of, reverse=True):
        point = Point(next(q for r in unit for q in r.positions))
        k = min(range(len(parts)), key=lambda k: (parts[k].distance(point), -free[k]))
        out[k] += unit
        free[k] -= area_of(unit)
    for unit in sorted((u for u in units if u not in pinned), key=area_of, reverse=True):
        named = [e for r in unit for e in edges_named(problem, edges, r.boundary)]
        facing = [k for k, p in enumerate(parts) if any(
            p.boundary.intersection(LineString([e.start, e.end])).length > 1e-3 for e in named)]
        roomy = [k for k in facing if free[k] >= area_of(unit) / 2]
        k = max(roomy or range(len(parts)), key=lambda k: free[k])
        out[k] += unit
        free[k] -= area_of(unit)
    return out


# 5. The whole.


@dataclass
class _Progress:
    """Events of the inner solves passed on, named after the stage."""

    on_event: EventSink | None
    started: float
    placed: dict[str, list[Box]] = field(default_factory=dict)

    def sink(self, stage: str, *, incumbents: bool) -> EventSink | None:
        if self.on_event is None:
            return None
        from solver.pipeline.solve import Phase

        def forward(event: object) -> None:
            assert self.on_event is not None
            rooms = getattr(event, "rooms", None)
            if getattr(event, "phase", None) is Phase.INCUMBENT:
                if not incumbents or rooms is None:
                    return
                rooms = self.placed | rooms
            if getattr(event, "phase", None) is Phase.DONE:
                return
            self.on_event(_replace(event, elapsed=time.monotonic() - self.started,
                                   detail=f"{stage}: {getattr(event, 'detail', '')}",
                                   rooms=rooms))
        return forward

    def say(self, detail: str, *, subdomain: int = 0, subdomains: int = 0) -> None:
        if self.on_event is None:
            return
        from solver.pipeline.solve import Phase, SolveEvent

        self.on_event(SolveEvent(phase=Phase.LEVEL, level=1,
                                 elapsed=time.monotonic() - self.started, detail=detail,
                                 subdomain=subdomain, subdomains=subdomains))


def _replace(event: object, **changes: object) -> object:
    import dataclasses

    return dataclasses.replace(event, **changes)  # type: ignore[type-var]


def solve_regions(
    problem: Problem,
    *,
    on_event: EventSink | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> Layout:
    """Lay out `problem` through regions and aisles (module docstring)."""
    from solver.geometry import make_domain
    from solver.pipeline.solve import default_time_limit, solve
    from solver.verify.precheck import find_impossibilities

    started = time.monotonic()
    flat = rooms_only(problem)
    if find_impossibilities(flat, make_domain(flat)):
        return solve(flat, on_event=on_event, should_stop=should_stop)
    limit = problem.options.time_limit or default_time_limit(len(problem.rooms))
    deadline = started + limit - min(limit * 0.1, FINISH_SECONDS_PER_ROOM * len(problem.rooms))
    progress = _Progress(on_event, started)
    bands = band_regions(problem) if problem.regions is None else None
    terminations: list[Termination] = []
    levels = 1
    if bands is not None:
        # An automatic partition: bars of rooms along aisles, planned.
        shapes: dict[str, Polygon] = dict(bands)
        given: Sequence[Region] = ()
        progress.say(f"regions: {len(shapes)} bars of rooms along aisles")
    else:
        given = partition(problem)
        progress.say(f"regions: {len(given)} regions of "
                     f"{', '.join(str(len(g.rooms)) for g in given)} rooms")
        level_one = region_problem(problem, given, max(1.0, min(
            limit * REGION_SHARE, REGION_SECONDS_PER_REGION * len(given))))
        laid = solve(level_one, on_event=progress.sink("regions", incumbents=False),
                     should_stop=should_stop)
        if not laid.rooms:
            if problem.regions is None and not (should_stop and should_stop()):
                # An automatic partition is only a means: solve flat instead.
                progress.say("regions: no region layout, solving without regions")
                return solve(flat.with_options(time_limit=max(1.0, deadline - time.monotonic())),
                             on_event=on_event, should_stop=should_stop)
            report = laid.report.model_copy(
                update={"solve_time": time.monotonic() - started})
            return Layout(name=problem.name, report=report)
        shapes = {r.id: Polygon(r.polygon) for r in laid.rooms}
        terminations.append(laid.report.termination)
        levels = laid.report.levels
    keep = _points_kept(problem, given, shapes)
    network = aisle_network(problem.free_area(), problem.outline(), shapes,
                            problem.aisle_width, entrance=problem.entrance, keep=keep)
    progress.say(f"aisles: {len(network.pieces)} aisle(s), "
                 f"{network.union.area:.1f} m²")
    jobs = _jobs(problem, list(shapes), given, network)
    placed: dict[str, list[Box]] = {}
    owner: dict[str, str] = {}
    left_rooms = len(problem.rooms)
    for k, (region_id, part, rooms) in enumerate(jobs):
        if should_stop is not None and should_stop():
            break
        share = max(MIN_PART_SECONDS, (deadline - time.monotonic()) * len(rooms) / left_rooms)
        left_rooms -= len(rooms)
        stage = f"region {region_id} {k + 1}/{len(jobs)}"
        progress.say(stage, subdomain=k + 1, subdomains=len(jobs))
        sub = room_problem(problem, part, rooms, share)
        if not slicing_has_demands(sub):
            # Sizes alone: slicing lays the rows out at once and the search after it
            # does not pay for its time (measured: no step improved on office-154).
            sub = sub.with_options(time_limit=min(
                share, MIN_PART_SECONDS + PART_SECONDS_PER_ROOM * len(rooms)))
        inner = solve(sub, on_event=progress.sink(stage, incumbents=True),
                      should_stop=should_stop)
        longer = max(share, (deadline - time.monotonic()) * len(rooms)
                     / (left_rooms + len(rooms)))
        if (not inner.rooms and inner.report.termination is Termination.NO_SOLUTION
                and longer > sub.options.time_limit
                and not (should_stop is not None and should_stop())):
            # The time ran out, not the constraints (a loaded machine, a part slicing
            # cannot lay out): the part's whole share before anything is given up.
            progress.say(f"{stage}: no layout yet, retrying with {longer:.1f} s")
            sub = sub.with_options(time_limit=longer)
            inner = solve(sub, on_event=progress.sink(stage, incumbents=True),
                          should_stop=should_stop)
        for relax in RELAXATIONS:
            if inner.rooms or (should_stop is not None and should_stop()):
                break
            # A part the region layout made awkward: keep the rooms, give up what
            # cannot hold there; the final check reports it against the user's problem.
            progress.say(f"{stage}: no layout, retrying without {', '.join(relax)}")
            sub = sub.model_copy(update={"rooms": [
                r.model_copy(update=dict.fromkeys(relax)) for r in sub.rooms]})
            sub = sub.with_options(time_limit=max(MIN_PART_SECONDS, share / 2))
            inner = solve(sub, should_stop=should_stop)
        terminations.append(inner.report.termination)
        levels = max(levels, inner.report.levels)
        for room in inner.rooms:
            placed[room.id] = [Box.of(rect) for rect in room.rectangles]
            owner[room.id] = region_id
        progress.placed = dict(placed)
    stopped = should_stop is not None and should_stop()
    return _merge(problem, list(shapes), network, placed, owner,
                  Termination.of_parts(terminations, interrupted=stopped), levels, started,
                  progress)


def _jobs(problem: Problem, region_ids: Sequence[str], given: Sequence[Region],
          network: AisleNetwork) -> list[tuple[str, Polygon, list[Room]]]:
    """The room sub-problems: per region part, its rooms. The user's regions (`given`)
    keep their rooms; an automatic partition is only a means, so its rooms are dealt
    over every part by the area the region layout actually gave (a region that came out
    smaller than planned gets fewer rooms, not squeezed ones), and a part that cannot
    hold what it was dealt (`find_impossibilities`: too narrow for a room's minimum
    size, say) is left out and the rooms dealt again, up to `DEAL_ROUNDS` times; the
    floor of a part left out joins the aisle it opens onto (`_with_leftovers`)."""
    if problem.regions is None:
        parts = [(g, part) for g in region_ids for part in network.parts[g]]
        jobs: list[tuple[str, Polygon, list[Room]]] = []
        for _ in range(DEAL_ROUNDS):
            dealt = assign_to_parts(problem, problem.rooms, [p for _, p in parts])
            jobs = [(g, part, rooms) for (g, part), rooms in zip(parts, dealt, strict=True)
                    if rooms]
            cannot = [k for k, (_, part, rooms) in enumerate(jobs)
                      if not _can_hold(problem, part, rooms)]
            if not cannot or len(cannot) == len(jobs):
                return jobs
            left_out = {id(jobs[k][1]) for k in cannot}
            parts = [(g, part) for g, part in parts if id(part) not in left_out]
        return jobs
    return [(g.id, part, rooms) for g in given
            for part, rooms in zip(network.parts[g.id],
                                   assign_to_parts(problem, [problem.room(r) for r in g.rooms],
                                                   network.parts[g.id]), strict=True)
            if rooms]


def _points_kept(problem: Problem, given: Sequence[Region],
                 shapes: Mapping[str, Polygon]) -> dict[str, list[tuple[float, float]]]:
    """Per region, the guide points its rooms must cover (an aisle keeps off them): the
    user's regions' rooms' points; else the points lying in the region's shape (a point
    on the wall between two goes to the first only, so the aisle keeps off its side)."""
    if given:
        return {g.id: [p for r in g.rooms for p in problem.room(r).positions] for g in given}
    kept: dict[str, list[tuple[float, float]]] = {g: [] for g in shapes}
    for point in (p for r in problem.rooms for p in r.positions):
        holder = next((g for g, shape in shapes.items()
                       if shape.buffer(1e-6).contains(Point(point))), None)
        if holder is not None:
            kept[holder].append(point)
    return kept


def _can_hold(problem: Problem, part: Polygon, rooms: Sequence[Room]) -> bool:
    """No cheap reason (solver/verify/precheck.py) why `rooms` cannot be laid out in `part`."""
    from solver.geometry import make_domain
    from solver.verify.precheck import find_impossibilities

    sub = room_problem(problem, part, rooms, 1.0)
    return not find_impossibilities(sub, make_domain(sub))


def _merge(problem: Problem, region_ids: Sequence[str], network: AisleNetwork,
           placed: Mapping[str, list[Box]], owner: Mapping[str, str],
           termination: Termination, levels: int, started: float,
           progress: _Progress) -> Layout:
    """One layout of every room and aisle, with doors, windows and the checks."""
    flat = rooms_only(problem)
    network = _with_leftovers(problem, network, placed)
    aisles = [Aisle(id=f"aisle-{k + 1}", polygon=polygon_coords(p.polygon),
                    rectangles=[b.to_rect() for b in rectangles_of(p.polygon)],
                    area=round(float(p.polygon.area), 6), width=problem.aisle_width,
                    regions=list(p.regions))
              for k, p in enumerate(network.pieces)]
    aisle_shapes = {a.id: p.polygon for a, p in zip(aisles, network.pieces, strict=True)}
    check = check_layout(flat, placed, aisles=list(aisle_shapes.values()))
    polygons = {r.id: room_polygon(placed[r.id]) for r in problem.rooms if r.id in placed}
    members = {g: [r for r in placed if owner.get(r) == g] for g in region_ids}
    aisle_checks = check_aisles(problem, polygons, aisle_shapes, members)
    doors = requested_doors(flat, polygons)
    doors += aisle_doors(problem, polygons, aisle_shapes)
    entry = entrance_door(problem, polygons, aisle_shapes)
    if entry is not None:
        doors.append(entry)
    doors += through_doors(problem, polygons, aisle_shapes, doors)
    windows = place_windows(flat, polygons, doors)
    circulation = walk_aisles(problem, doors, aisle_shapes)
    access = [r.id for r in problem.rooms if r.id in polygons and not any(
        d.between == (a, r.id) for d in doors for a in aisle_shapes)]
    constraints = [*check.constraints, *aisle_checks, ConstraintCheck(
        kind="aisle_access", rooms=access, satisfied=not access,
        detail="every room has a door onto an aisle" if not access else
        f"{len(access)} room(s) reached through a neighbour, not from an aisle")]
    valid = all(c.satisfied for c in constraints if c.kind not in SOFT_KINDS)
    w = problem.weights
    objective = w.cover * check.uncovered_area + w.size * sum(check.size_error.values())
    rooms = [RoomLayout(id=r.id, type=r.type, polygon=polygon_coords(polygons[r.id]),
                        rectangles=[b.to_rect() for b in placed[r.id]],
                        area=round(float(polygons[r.id].area), 6), region=owner.get(r.id))
             for r in problem.rooms if r.id in polygons]
    report = Report(coverage=check.coverage, uncovered_area=check.uncovered_area,
                    constraints=constraints, size_error=check.size_error, objective=objective,
                    levels=levels, solve_time=time.monotonic() - started,
                    termination=termination, valid=valid, circulation=circulation)
    if progress.on_event is not None:
        from solver.pipeline.solve import Phase, SolveEvent

        progress.on_event(SolveEvent(phase=Phase.DONE, level=levels,
                                     elapsed=time.monotonic() - started, objective=objective,
                                     detail=f"coverage {check.coverage:.1%} (aisles included)"))
    return Layout(name=problem.name, rooms=rooms, doors=doors, windows=windows, aisles=aisles,
                  report=report)


def _with_leftovers(problem: Problem, network: AisleNetwork,
                    placed: Mapping[str, list[Box]]) -> AisleNetwork:
    """Floor a region's rooms left uncovered where it opens onto an aisle widens that
    aisle (an alcove), rather than staying a gap in the plan."""
    rooms = shapely.union_all([b.to_polygon() for boxes in placed.values() for b in boxes])
    current = network.union
    left = problem.free_area().difference(rooms).difference(current)
    extra = [p for p in getattr(left, "geoms", [left]) if isinstance(p, Polygon)
             and p.area > 1e-3 and p.boundary.intersection(current.boundary).length > 0.1]
    if not extra:
        return network
    grown = aisle_pieces([*(p.polygon for p in network.pieces), *extra], problem.free_area(),
                         {}, keep_regions=[p.regions for p in network.pieces])
    return AisleNetwork(grown, network.parts)


# Doors and circulation with aisles: aisles are corridors that are not rooms.


def aisle_doors(problem: Problem, rooms: Mapping[str, Polygon],
                aisles: Mapping[str, Polygon]) -> list[Door]:
    """A door from each room onto the aisle it shares the longest wall with."""
    doors = []
    width = problem.openings.door_width
    for room_id, polygon in rooms.items():
        walls = [(wall, a) for a, shape in aisles.items()
                 if (wall := longest_shared_wall(polygon, shape)) is not None]
        if not walls:
            continue
        wall, aisle = max(walls, key=lambda w: w[0].length)
        segment = _door_segment(wall, width)
        if segment is not None:
            doors.append(Door(between=(aisle, room_id), segment=segment, opens_into=room_id,
                              requested=False))
    return doors


def entrance_door(problem: Problem, rooms: Mapping[str, Polygon],
                  aisles: Mapping[str, Polygon]) -> Door | None:
    """The front door, into the aisle at the entrance (else into the room there)."""
    return front_door(problem, aisles) or front_door(rooms_only(problem), rooms)


def through_doors(problem: Problem, rooms: Mapping[str, Polygon],
                  aisles: Mapping[str, Polygon], doors: list[Door]) -> list[Door]:
    """A room touching no aisle gets a door onto the neighbour with the longest wall
    that is already reached from an aisle (the door policy allowing)."""
    added: list[Door] = []
    width = problem.openings.door_width
    ends = {r.id for r in problem.rooms if r.type in problem.openings.no_passage}
    reached = set(_steps(problem, doors, aisles, from_aisles=True))
    names = list(rooms)
    tree = shapely.STRtree([rooms[n] for n in names])
    walls: dict[str, list[tuple[float, str, LineString]]] = {}
    for room_id in names:
        if room_id in reached:
            continue
        for j in tree.query(rooms[room_id], "touches"):
            other = names[int(j)]
            if other == room_id or not may_connect(problem, room_id, other):
                continue
            wall = longest_shared_wall(rooms[room_id], rooms[other])
            if wall is not None and wall.length >= width - 1e-4:
                walls.setdefault(room_id, []).append((wall.length, other, wall))
    while True:
        options = [(length, room_id, other, wall) for room_id, found in walls.items()
                   if room_id not in reached for length, other, wall in found
                   if other in reached and other not in ends]
        if not options:
            return added
        _, room_id, other, wall = max(options, key=lambda o: o[0])
        segment = _door_segment(wall, width)
        assert segment is not None
        added.append(Door(between=(other, room_id), segment=segment, opens_into=room_id,
                          requested=False))
        reached.add(room_id)


def _steps(problem: Problem, doors: Sequence[Door], aisles: Mapping[str, Polygon], *,
           from_aisles: bool = False) -> dict[str, int]:
    """Doors passed from outside (or from any aisle) to each place; moving between two
    aisles that meet passes no door. Never through an end room (a bathroom)."""
    links: dict[str, set[str]] = {}
    for door in doors:
        a, b = door.between
        links.setdefault(a, set()).add(b)
        links.setdefault(b, set()).add(a)
    ends = {r.id for r in problem.rooms if r.type in problem.openings.no_passage}
    names = list(aisles)
    free: dict[str, set[str]] = {a: set() for a in names}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if aisles[a].intersection(aisles[b]).length > 1e-3:
                free[a].add(b)
                free[b].add(a)
    outline = problem.outline().exterior
    if from_aisles:
        starts = names
    elif problem.entrance is not None:
        starts = [OUTSIDE]
    else:  # the aisles' facade ends are the exits
        starts = [OUTSIDE]
        for a in names:
            if aisles[a].exterior.intersection(outline).length > 1e-3:
                free.setdefault(OUTSIDE, set()).add(a)
    steps = dict.fromkeys(starts, 0)
    queue = deque(starts)
    while queue:
        here = queue.popleft()
        if here in ends:
            continue
        for there in sorted(free.get(here, set())):
            if there not in steps or steps[there] > steps[here]:
                steps[there] = steps[here]
                queue.appendleft(there)
        for there in sorted(links.get(here, set())):
            if there not in steps:
                steps[there] = steps[here] + 1
                queue.append(there)
    return steps


def walk_aisles(problem: Problem, doors: Sequence[Door],
                aisles: Mapping[str, Polygon]) -> Circulation:
    """The circulation report, walked from outside through the aisles and doors."""
    steps = _steps(problem, doors, aisles)
    room_steps = {r.id: steps[r.id] for r in problem.rooms if r.id in steps}
    unreachable = [r.id for r in problem.rooms if r.id not in steps]
    degree: dict[str, int] = {}
    for door in doors:
        for name in door.between:
            degree[name] = degree.get(name, 0) + 1
    dead_ends = [r.id for r in problem.rooms if degree.get(r.id, 0) == 1]
    return Circulation(reachable=not unreachable, unreachable=unreachable, steps=room_steps,
                       furthest=max(room_steps.values(), default=0), dead_ends=dead_ends)
