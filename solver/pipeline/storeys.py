"""Buildings of several storeys (paper Fig. 11; docs/method.md, "Several storeys"): one
layout per floor, the vertical rooms (stairs, lifts, shafts) on the very same footprint
on every floor.

Each floor is an ordinary single-floor problem (`models.storeys.floor_problem`) and is
solved by `solver.solve` (handed in as `solve`). The floors are solved one after the other: first an
*anchor* floor, where the vertical rooms are placed freely with the floor's own rooms,
then every other floor with the vertical rooms already placed *pinned*: each becomes a
room whose minimum and maximum size are its footprint's and whose guide points are two
opposite corners of it (C_size and C_pos of the paper, Eq. 5 and 8), so the MIQP can
place it nowhere else, and the hierarchy cannot change it either (halves cover their
parent, and the bounding box may not outgrow the maximum). The floor's other rooms are
laid out around it, and their adjacencies to it hold as on any floor.

The anchor is the floor with the most vertical rooms, then the most demands on them,
then the least free area. If a later floor cannot take the pinned footprint (it falls
outside that floor's outline or on an obstacle, or the floor is infeasible or finds
nothing with it), the next candidate anchor is tried, as long as time is left; the
answer says which floor failed and why. A vertical room whose footprint at the anchor
is not one rectangle (refinement made it an L) is pinned by its bounding box and the
anchor floor solved again with it pinned, so that every floor has the same shape.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import shapely
from shapely.geometry.base import BaseGeometry

from floorplan.models import (
    ConflictItem,
    ConflictSet,
    ConstraintCheck,
    FloorLayout,
    Infeasibility,
    Layout,
    Problem,
    Report,
    Termination,
)
from floorplan.models.storeys import (
    common_free_area,
    floor_problem,
    spanned_floors,
    user_path,
    verticals_on,
)
from floorplan.solver.budget import default_time_limit, late_allowance
from floorplan.solver.events import EventSink, Solve, SolveEvent
from floorplan.solver.geometry import Box, bounding_box
from floorplan.solver.pipeline.subdomains import SubdomainExecutor

#: Two footprints are the same when they differ by less than this area (m²) ...
SAME_FOOTPRINT_AREA = 1e-6
#: ... and output coordinates this close (metres) to a pinned footprint's are set to it
#: exactly (SCIP places a pinned room within its feasibility tolerance).
PIN_SNAP = 1e-4
#: An anchor is not tried again with less than this many seconds left.
MIN_ATTEMPT_SECONDS = 0.5

def job_time_limit(problem: Problem) -> float:
    """The whole job's time limit: `options.time_limit`, else each floor's default
    (5 s up to 20 rooms, then in proportion) added up."""
    if problem.options.time_limit is not None:
        return problem.options.time_limit
    if problem.floors is None:
        return default_time_limit(len(problem.rooms))
    return sum(default_time_limit(len(floor.rooms) + len(verticals_on(problem, floor.id)))
               for floor in problem.floors)


def job_ceiling(problem: Problem) -> float:
    """The longest the job may run: `job_time_limit`, and for one floor under the
    default limit the first layout's late allowance (`solver.budget.late_allowance`)."""
    limit = job_time_limit(problem)
    if problem.options.time_limit is None and problem.floors is None:
        return max(limit, late_allowance(len(problem.rooms)))
    return limit


@dataclass
class _Attempt:
    """One pass over the floors from one anchor."""

    anchor: int
    seed: int
    #: Floor index -> its layout, for the floors solved so far.
    layouts: dict[int, Layout] = field(default_factory=dict)
    #: Vertical room id -> its pinned footprint, and the vertices of its polygon there
    #: (the polygon is on a finer grid than the rectangles: both are matched).
    pinned: dict[str, list[Box]] = field(default_factory=dict)
    outlines: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    #: Vertical room id -> the floor it was placed on.
    placed_on: dict[str, str] = field(default_factory=dict)
    #: The floor that failed, its layout (without rooms) or None, and why.
    failed: int | None = None
    failure: Layout | None = None
    why: str = ""


def solve_storeys(
    problem: Problem,
    *,
    solve: Solve,
    on_event: EventSink | None = None,
    should_stop: Callable[[], bool] | None = None,
    subdomains: SubdomainExecutor | None = None,
) -> Layout:
    """Lay out every floor of `problem` with its vertical rooms aligned; never raises
    for a well-formed problem (a failure is a report saying which floor and why).
    Each floor is laid out by `solve`."""
    assert problem.floors is not None
    started = time.monotonic()
    deadline = started + job_time_limit(problem)
    floors = [floor_problem(problem, i) for i in range(len(problem.floors))]
    weights = [job_time_limit(f.with_options(time_limit=None)) for f in floors]
    tried: list[str] = []
    attempts: list[_Attempt] = []
    for anchor in _anchor_order(problem, floors):
        if attempts and (deadline - time.monotonic() < MIN_ATTEMPT_SECONDS
                         or _stopped(should_stop)):
            break
        attempt = _Attempt(anchor, problem.options.seed)
        _run_attempt(problem, floors, weights, attempt, deadline, started, solve, on_event,
                     should_stop, subdomains)
        attempts.append(attempt)
        if attempt.failed is None:
            return _building_layout(problem, attempt, started, should_stop)
        tried.append(f"anchored on floor '{_floor_id(problem, anchor)}': {attempt.why}")
        if _stopped(should_stop) or _proven_infeasible(attempt):
            break
    return _failure(problem, attempts, tried, started, should_stop)


def _anchor_order(problem: Problem, floors: list[Problem]) -> list[int]:
    """Candidate anchors, best first: most vertical rooms, most demands on them (their
    adjacencies on the floor), least free area."""
    assert problem.floors is not None

    def key(i: int) -> tuple[float, ...]:
        floor = problem.floors[i]  # type: ignore[index]
        ids = {problem.vertical[j].id for j in verticals_on(problem, floor.id)}
        demands = sum(1 for adj in floor.adjacency if ids & {adj.a, *adj.partners})
        return (-len(ids), -demands, floors[i].free_area().area, i)

    return sorted(range(len(floors)), key=key)


def _floor_order(problem: Problem, anchor: int, floors: list[Problem]) -> list[int]:
    """The anchor, then each time the floor with the most vertical rooms not placed yet
    (placed freely there), ties as for the anchors."""
    assert problem.floors is not None
    order = [anchor]
    placed = {problem.vertical[j].id for j in verticals_on(problem, problem.floors[anchor].id)}
    ranking = _anchor_order(problem, floors)
    while len(order) < len(floors):
        rest = [i for i in ranking if i not in order]
        unplaced = {i: sum(1 for j in verticals_on(problem, problem.floors[i].id)
                           if problem.vertical[j].id not in placed) for i in rest}
        best = max(rest, key=lambda i: (unplaced[i], -rest.index(i)))
        order.append(best)
        placed |= {problem.vertical[j].id
                   for j in verticals_on(problem, problem.floors[best].id)}
    return order


def _run_attempt(
    problem: Problem, floors: list[Problem], weights: list[float], attempt: _Attempt,
    deadline: float, started: float, solve: Solve, on_event: EventSink | None,
    should_stop: Callable[[], bool] | None, subdomains: SubdomainExecutor | None,
) -> None:
    """Solve every floor from `attempt.anchor`, pinning each vertical room once placed;
    a failure ends the attempt (recorded in it)."""
    assert problem.floors is not None
    order = _floor_order(problem, attempt.anchor, floors)
    queue = list(order)
    again: set[int] = set()  # floors to solve again with a bounding box pinned
    while queue:
        i = queue.pop(0)
        floor_id = problem.floors[i].id
        if _stopped(should_stop):
            # Each floor's solve would end at once, but only after building its model:
            # a cancelled 100-floor job took 25 s to end.
            attempt.failed, attempt.why = i, f"stopped before floor '{floor_id}'"
            return
        left = [i, *queue]
        budget = max(deadline - time.monotonic(), 0.05) * weights[i] / sum(
            weights[j] for j in left)
        pins = {v: boxes for v, boxes in attempt.pinned.items()
                if any(problem.vertical[j].id == v for j in verticals_on(problem, floor_id))}
        misfit = _misfit(problem, i, pins)
        if misfit:
            attempt.failed, attempt.why = i, misfit
            return
        floor = _pinned(floors[i], pins)
        floor = floor.with_options(time_limit=budget, seed=attempt.seed)
        layout = _solve_floor(solve, floor, floor_id, started, on_event, should_stop,
                              subdomains)
        if not layout.rooms:
            attempt.failed, attempt.failure = i, layout
            reason = layout.report.infeasibility.reason if layout.report.infeasibility else ""
            pinned = f" with {', '.join(sorted(pins))} pinned" if pins else ""
            attempt.why = f"floor '{floor_id}'{pinned}: {layout.report.termination.value}" + (
                f" ({reason})" if reason else "")
            return
        if pins:
            layout = _snapped(layout, pins, attempt.outlines)
        attempt.layouts[i] = layout
        for j in verticals_on(problem, floor_id):
            vertical = problem.vertical[j]
            if vertical.id in attempt.pinned:
                continue
            boxes = _footprint(layout, vertical.id)
            outline = next(r.polygon for r in layout.rooms if r.id == vertical.id)
            if len(boxes) > 1:  # an L or T: every floor gets the bounding box
                boxes = [bounding_box(boxes)]
                b = boxes[0]
                outline = [(b.x0, b.y0), (b.x1, b.y0), (b.x1, b.y1), (b.x0, b.y1)]
                again.add(i)
            attempt.pinned[vertical.id] = boxes
            attempt.outlines[vertical.id] = outline
            attempt.placed_on[vertical.id] = floor_id
            fits = _misfit_anywhere(problem, vertical.id, boxes)
            if fits:
                attempt.failed, attempt.why = i, fits
                return
        if not queue and again:
            queue, again = sorted(again), set()


def _solve_floor(
    solve: Solve, floor: Problem, floor_id: str, started: float, on_event: EventSink | None,
    should_stop: Callable[[], bool] | None, subdomains: SubdomainExecutor | None,
) -> Layout:
    """One floor by the single-floor pipeline; its events name the floor and count time
    from the job's start."""
    def relay(event: SolveEvent) -> None:
        assert on_event is not None
        on_event(replace(event, floor=floor_id, elapsed=time.monotonic() - started,
                         detail=f"floor {floor_id}: {event.detail}" if event.detail
                         else f"floor {floor_id}"))

    return solve(floor, on_event=relay if on_event is not None else None,
                 should_stop=should_stop, subdomains=subdomains)


def _pinned(floor: Problem, pins: dict[str, list[Box]]) -> Problem:
    """`floor` with each room of `pins` held at its footprint (one rectangle): its size
    exact (C_size) and two opposite corners to cover (C_pos); its own boundary demands,
    ratio and target already hold there."""
    if not pins:
        return floor
    rooms = []
    for room in floor.rooms:
        if room.id not in pins:
            rooms.append(room)
            continue
        (b,) = pins[room.id]
        rooms.append(room.model_copy(update={
            "min_size": (b.width, b.depth), "max_size": (b.width, b.depth),
            "target_size": (b.width, b.depth), "aspect_ratio": None,
            "positions": [(b.x0, b.y0), (b.x1, b.y1)], "boundary": [],
            "shape": "rectangle", "max_rects": 1,
        }))
    return floor.model_copy(update={"rooms": rooms})


def _footprint(layout: Layout, room_id: str) -> list[Box]:
    for room in layout.rooms:
        if room.id == room_id:
            return [Box.of(r) for r in room.rectangles]
    return []


def _footprint_shape(boxes: list[Box]) -> BaseGeometry:
    return shapely.union_all([b.to_polygon() for b in boxes])


def _misfit(problem: Problem, index: int, pins: dict[str, list[Box]]) -> str:
    """Why the pinned footprints cannot stand on floor `index` ('' when they can)."""
    assert problem.floors is not None
    floor_id = problem.floors[index].id
    free = common_free_area(problem, [floor_id])
    for room_id, boxes in sorted(pins.items()):
        outside = _footprint_shape(boxes).difference(free).area
        if outside > SAME_FOOTPRINT_AREA:
            return (f"the footprint of '{room_id}' lies {outside:.2f} m² outside floor "
                    f"'{floor_id}' (its outline or obstacles)")
    return ""


def _misfit_anywhere(problem: Problem, room_id: str, boxes: list[Box]) -> str:
    """Why `room_id`'s footprint cannot stand on some floor it spans ('' when it can)."""
    assert problem.floors is not None
    vertical = next(v for v in problem.vertical if v.id == room_id)
    for index, floor in enumerate(problem.floors):
        if floor.id in spanned_floors(problem, vertical):
            why = _misfit(problem, index, {room_id: boxes})
            if why:
                return why
    return ""


def _snapped(
    layout: Layout, pins: dict[str, list[Box]], outlines: dict[str, list[tuple[float, float]]]
) -> Layout:
    """`layout` with every coordinate within `PIN_SNAP` of a pinned footprint's set to
    it exactly (rectangles to its rectangles', polygons and openings to its polygon's),
    so that the footprint is the very same on every floor."""
    def snapper(values: set[float]) -> Callable[[float], float]:
        ordered = sorted(values)
        return lambda v: next((w for w in ordered if abs(w - v) <= PIN_SNAP), v)

    rx = snapper({v for boxes in pins.values() for b in boxes for v in (b.x0, b.x1)})
    ry = snapper({v for boxes in pins.values() for b in boxes for v in (b.y0, b.y1)})
    sx = snapper({x for room_id in pins for x, _ in outlines[room_id]})
    sy = snapper({y for room_id in pins for _, y in outlines[room_id]})

    def point(p: tuple[float, float]) -> tuple[float, float]:
        return (sx(p[0]), sy(p[1]))

    rooms = []
    for room in layout.rooms:
        rects = [Box(rx(b.x0), ry(b.y0), rx(b.x1), ry(b.y1))
                 for b in (Box.of(r) for r in room.rectangles)]
        polygon = [point(p) for p in room.polygon]
        area = float(shapely.Polygon(polygon).area) if len(polygon) >= 3 else room.area
        rooms.append(room.model_copy(update={
            "rectangles": [b.to_rect() for b in rects], "polygon": polygon,
            "area": round(area, 6)}))
    doors = [d.model_copy(update={"segment": (point(d.segment[0]), point(d.segment[1]))})
             for d in layout.doors]
    windows = [w.model_copy(update={"segment": (point(w.segment[0]), point(w.segment[1]))})
               for w in layout.windows]
    return layout.model_copy(update={"rooms": rooms, "doors": doors, "windows": windows})


def vertical_checks(problem: Problem, floors: list[FloorLayout]) -> list[ConstraintCheck]:
    """One `vertical` check per vertical room, on the polygons alone: satisfied iff it
    is laid out on every floor it spans, with the same footprint on each."""
    by_id = {f.id: f for f in floors}
    checks = []
    for vertical in problem.vertical:
        spans = spanned_floors(problem, vertical)
        shapes: dict[str, BaseGeometry] = {}
        for floor_id in spans:
            floor = by_id.get(floor_id)
            room = next((r for r in floor.rooms if r.id == vertical.id), None) if floor else None
            if room is not None and len(room.polygon) >= 3:
                shapes[floor_id] = shapely.Polygon(room.polygon)
        missing = [f for f in spans if f not in shapes]
        reference = shapes.get(spans[0])
        differs = [f for f, s in shapes.items() if reference is not None
                   and s.symmetric_difference(reference).area > SAME_FOOTPRINT_AREA]
        satisfied = not missing and not differs
        if satisfied:
            detail = f"the same footprint on floors {', '.join(spans)}"
        elif missing:
            detail = f"not laid out on floor(s) {', '.join(missing)}"
        else:
            detail = (f"footprint on floor(s) {', '.join(differs)} differs from floor "
                      f"{spans[0]}'s")
        checks.append(ConstraintCheck(kind="vertical", rooms=[vertical.id],
                                      satisfied=satisfied, detail=detail))
    return checks


def _building_layout(
    problem: Problem, attempt: _Attempt, started: float,
    should_stop: Callable[[], bool] | None, failure: Infeasibility | None = None,
) -> Layout:
    """The floors' layouts in the problem's order and the building's report."""
    assert problem.floors is not None
    floors = [
        FloorLayout(id=floor.id, name=floor.name or floor.id, rooms=layout.rooms,
                    doors=layout.doors, windows=layout.windows, report=layout.report)
        for i, floor in enumerate(problem.floors)
        if (layout := attempt.layouts.get(i)) is not None
    ]
    reports = [f.report for f in floors]
    free = {floor.id: floor_problem(problem, i).free_area().area
            for i, floor in enumerate(problem.floors)}
    area = sum(free[f.id] for f in floors)
    covered = sum(free[f.id] * f.report.coverage for f in floors)
    verticals = vertical_checks(problem, floors)
    constraints = [*verticals, *(c.model_copy(update={"floor": f.id})
                                 for f in floors for c in f.report.constraints)]
    complete = len(floors) == len(problem.floors)
    each = [r.termination for r in reports]
    valid = complete and all(r.valid for r in reports) and all(c.satisfied for c in verticals)
    objectives = [r.objective for r in reports]
    report = Report(
        coverage=covered / area if area else 0.0,
        uncovered_area=sum(r.uncovered_area for r in reports),
        constraints=constraints,
        size_error={f"{f.id}/{room}": e for f in floors
                    for room, e in f.report.size_error.items()},
        objective=None if any(o is None for o in objectives) else sum(
            o for o in objectives if o is not None),
        levels=max((r.levels for r in reports), default=0),
        solve_time=time.monotonic() - started,
        termination=Termination.of_parts(each, interrupted=_stopped(should_stop) or (
            Termination.INTERRUPTED in each) or not complete),
        valid=valid,
        infeasibility=failure,
        extra_rectangles=[e.model_copy(update={"room": f"{f.id}/{e.room}"})
                          for f in floors for e in f.report.extra_rectangles],
        violations=[v.model_copy(update={"floor": f.id}) for f in floors
                    for v in f.report.violations],
        total_shortfall=sum(f.report.total_shortfall for f in floors),
    )
    return Layout(name=problem.name, report=report, floors=floors)


def _proven_infeasible(attempt: _Attempt) -> bool:
    """A floor proved infeasible with no vertical room pinned on it: the building is
    infeasible whatever the anchor."""
    failure = attempt.failure
    return (failure is not None and failure.report.termination is Termination.INFEASIBLE
            and attempt.failed == attempt.anchor)


def _failure(
    problem: Problem, attempts: list[_Attempt], tried: list[str], started: float,
    should_stop: Callable[[], bool] | None,
) -> Layout:
    """No aligned layout of every floor: the report names the floor that failed."""
    assert problem.floors is not None
    last = attempts[-1]
    floor_id = problem.floors[last.failed if last.failed is not None else 0].id
    inner = last.failure.report.infeasibility if last.failure is not None else None
    if _stopped(should_stop):
        termination = Termination.INTERRUPTED
    elif _proven_infeasible(last):
        termination = Termination.INFEASIBLE
    else:
        termination = Termination.NO_SOLUTION
    why = Infeasibility(
        reason=f"floor '{floor_id}': " + (inner.reason if inner is not None else last.why),
        findings=[f"floor '{floor_id}': {f}" for f in (inner.findings if inner else [])],
        active_families=inner.active_families if inner else [],
        relaxations_tried=[*tried, *(f"floor '{floor_id}': {r}"
                                     for r in (inner.relaxations_tried if inner else []))],
        conflict=_user_conflict(problem, floor_id, inner, {
            room: placed for room, placed in last.placed_on.items() if placed != floor_id}),
    )
    if termination is Termination.INTERRUPTED and last.layouts:
        # The floors laid out before the stop are the best layout so far.
        return _building_layout(problem, last, started, should_stop, failure=why)
    report = Report(coverage=0.0, uncovered_area=0.0, termination=termination, valid=False,
                    infeasibility=why, solve_time=time.monotonic() - started)
    return Layout(name=problem.name, report=report)


def _user_conflict(
    problem: Problem, floor_id: str, inner: Infeasibility | None, pinned: dict[str, str],
) -> ConflictSet | None:
    """The failed floor's explained conflict with paths into the user's problem. The
    sizes and corner points that pinned a vertical room (`pinned`: room -> the floor
    that placed it) become one item: the room stands where that floor put it."""
    if inner is None or inner.conflict is None:
        return None
    items: list[ConflictItem] = []
    for c in inner.conflict.constraints:
        path = user_path(problem, floor_id, c.path)
        room = c.rooms[0] if len(c.rooms) == 1 else ""
        if room in pinned and c.kind in ("min_size", "max_size", "position"):
            path = ".".join(path.split(".")[:2])  # vertical.J
            if any(i.path == path for i in items):
                continue
            c = c.model_copy(update={
                "kind": "vertical", "constraint": f"{room} pinned by floor {pinned[room]}",
                "phrase": f"'{room}' must stand where floor '{pinned[room]}' put it"})
        items.append(c.model_copy(update={"path": path}))
    return inner.conflict.model_copy(update={"constraints": items})


def _stopped(should_stop: Callable[[], bool] | None) -> bool:
    return should_stop is not None and should_stop()


def _floor_id(problem: Problem, index: int) -> str:
    assert problem.floors is not None
    return problem.floors[index].id

