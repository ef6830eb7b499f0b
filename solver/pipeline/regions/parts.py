"""Large layouts, step 4: the rooms of each region part as an ordinary problem, and
which rooms go to which part."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from shapely.geometry import LineString, Point, Polygon

from floorplan.models import (
    Problem,
    Region,
    Room,
)
from floorplan.solver.geometry import (
    Edge,
    boundary_edges,
    edges_named,
    make_domain,
    polygon_coords,
    rectangles_of,
)
from floorplan.solver.pipeline.regions.aisles import AisleNetwork
from floorplan.solver.pipeline.regions.partition import (
    room_adjacency,
    room_area,
    room_units,
    typical_area,
)
from floorplan.solver.verify.precheck import find_impossibilities

#: Rounds of dealing an automatic partition's rooms again when a part cannot hold them.
DEAL_ROUNDS = 3


def polygon_pieces(geometry: object) -> list[Polygon]:
    return [g for g in getattr(geometry, "geoms", [geometry])
            if isinstance(g, Polygon) and not g.is_empty]


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
    assert isinstance(sub, Edge) and isinstance(building, Edge)
    if sub.facing != building.facing or abs(sub.line - building.line) > 1e-6:
        return False
    lo, hi = sub.span
    blo, bhi = building.span
    return min(hi, bhi) - max(lo, blo) > 1e-6


def assign_to_parts(problem: Problem, rooms: Sequence[Room], parts: Sequence[Polygon],
                    capacity: Callable[[Polygon], float] | None = None,
                    fit: Callable[[Polygon, Room], float] | None = None,
                    most: Callable[[Polygon], int | None] | None = None) -> list[list[Room]]:
    """Share out `rooms` among region parts in proportion to their area (or
    `capacity`, the floor a part can give its rooms): units of rooms
    joined by adjacencies stay together; units with a guide point go to the part holding
    it (else the nearest), then the others, largest first, to the part with the most area
    left, among those touching an exterior wall the unit asks for when there are any.
    With `fit` (how badly a room's target suits a part, 0 at best), a unit goes to the
    part it fits best among those with its area left, the most area left breaking ties.
    With `most` (the most rooms a part may take, None: any), a part that has them is
    passed over, and a part of one room is dealt the largest unit of one room that
    fits its area first."""
    if len(parts) <= 1:
        return [list(rooms)] if parts else []
    typical = typical_area(problem)
    ids = {r.id for r in rooms}
    sub = problem.model_copy(update={"rooms": list(rooms), "adjacency": [
        a for a in room_adjacency(problem) if a.a in ids and set(a.partners) <= ids]})
    units = room_units(sub)
    total = sum(room_area(r, typical) for r in rooms)
    sizes = [capacity(p) if capacity is not None else p.area for p in parts]
    room_share = total / sum(sizes)
    free = [size * room_share for size in sizes]
    out: list[list[Room]] = [[] for _ in parts]
    edges = boundary_edges(problem.boundary)

    def area_of(unit: Sequence[Room]) -> float:
        return sum(room_area(r, typical) for r in unit)

    limits = [most(p) if most is not None else None for p in parts]

    def full(k: int) -> bool:
        return limits[k] is not None and len(out[k]) >= limits[k]  # type: ignore[operator]

    pinned = [u for u in units if any(r.positions for r in u)]
    for k, limit in enumerate(limits):
        # A one-room part first gets the largest single room its floor holds.
        if limit == 1:
            taken = {id(r) for w in out for r in w}
            lone = [u for u in units if len(u) == 1 and u not in pinned
                    and area_of(u) <= free[k] and id(u[0]) not in taken]
            if lone:
                unit = max(lone, key=area_of)
                out[k] += unit
                free[k] -= area_of(unit)
    for unit in sorted(pinned, key=area_of, reverse=True):
        point = Point(next(q for r in unit for q in r.positions))
        k = min(range(len(parts)), key=lambda k: (parts[k].distance(point), -free[k]))
        out[k] += unit
        free[k] -= area_of(unit)
    given = {id(r) for w in out for r in w}
    for unit in sorted((u for u in units if u not in pinned and id(u[0]) not in given),
                       key=area_of, reverse=True):
        named = [e for r in unit for e in edges_named(problem, edges, r.boundary)]
        facing = [k for k, p in enumerate(parts) if any(
            p.boundary.intersection(LineString([e.start, e.end])).length > 1e-3 for e in named)]
        open_ = [k for k in range(len(parts)) if not full(k)] or list(range(len(parts)))
        roomy = [k for k in facing if free[k] >= area_of(unit) / 2 and k in open_]
        if fit is not None and not roomy:
            fitting = [k for k in open_ if free[k] >= area_of(unit)]
            k = min(fitting, key=lambda k: (sum(fit(parts[k], r) for r in unit), -free[k]),
                    default=max(open_, key=lambda k: free[k]))
        else:
            k = max(roomy or open_, key=lambda k: free[k])
        out[k] += unit
        free[k] -= area_of(unit)
    return out


def region_jobs(problem: Problem, region_ids: Sequence[str], given: Sequence[Region],
                network: AisleNetwork, capacity: Callable[[Polygon], float] | None = None,
                fit: Callable[[Polygon, Room], float] | None = None,
                most: Callable[[Polygon], int | None] | None = None,
                ) -> list[tuple[str, Polygon, list[Room]]]:
    """The room sub-problems: per region part, its rooms. The user's regions (`given`)
    keep their rooms, dealt over that region's own parts; an automatic partition is only
    a means, so its rooms are dealt over every part. Either way the rooms are dealt by
    the area the region layout actually gave (a region part that came out smaller than
    planned gets fewer rooms, not squeezed ones) and again without the parts that cannot
    hold what they were dealt (`_dealt`)."""
    if problem.regions is None:
        parts = [(g, part) for g in region_ids for part in network.parts[g]]
        return _dealt(problem, problem.rooms, parts, capacity, fit, most)
    return [job for g in given for job in _dealt(
        problem, [problem.room(r) for r in g.rooms], [(g.id, p) for p in network.parts[g.id]])]


def _dealt(problem: Problem, rooms: Sequence[Room], parts: Sequence[tuple[str, Polygon]],
           capacity: Callable[[Polygon], float] | None = None,
           fit: Callable[[Polygon, Room], float] | None = None,
           most: Callable[[Polygon], int | None] | None = None,
           ) -> list[tuple[str, Polygon, list[Room]]]:
    """`rooms` dealt over `parts` (region id, part) by area (`assign_to_parts`); a part
    that cannot hold what it was dealt (`find_impossibilities`: too narrow for a room's
    minimum size, a sliver the region layout left, say) is left out and the rooms dealt
    again, up to `DEAL_ROUNDS` times; the floor of a part left out joins the aisle it
    opens onto (`_with_leftovers`)."""
    parts = list(parts)
    jobs: list[tuple[str, Polygon, list[Room]]] = []
    for _ in range(DEAL_ROUNDS):
        dealt = assign_to_parts(problem, rooms, [p for _, p in parts], capacity, fit, most)
        jobs = [(g, part, dealt_rooms)
                for (g, part), dealt_rooms in zip(parts, dealt, strict=True) if dealt_rooms]
        cannot = [k for k, (_, part, dealt_rooms) in enumerate(jobs)
                  if not can_hold(problem, part, dealt_rooms)]
        if not cannot or len(cannot) == len(jobs):
            return jobs
        left_out = {id(jobs[k][1]) for k in cannot}
        parts = [(g, part) for g, part in parts if id(part) not in left_out]
    return jobs


def points_kept(problem: Problem, given: Sequence[Region],
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


def can_hold(problem: Problem, part: Polygon, rooms: Sequence[Room]) -> bool:
    """No cheap reason (solver/verify/precheck.py) why `rooms` cannot be laid out in `part`."""
    sub = room_problem(problem, part, rooms, 1.0)
    return not find_impossibilities(sub, make_domain(sub))
