"""Fixed rooms (docs/problem.md, "Fixed rooms"): rooms whose polygon the user gives
(`Room.fixed`), the other rooms laid out around them.

A fixed room is *pinned* as the storeys pin a vertical room on a later floor
(`solver.pipeline.storeys`): its polygon's largest rectangle becomes the room, with
its size exact (C_size) and two opposite corners to cover (C_pos), so the MIQP can put
it nowhere else and the hierarchy cannot change it (halves cover their parent, the
bounding box may not outgrow the maximum); the rest of an L- or T-shaped polygon
becomes obstacles. The free rooms are laid out around it by the ordinary pipeline, and
their adjacencies to it hold as to any room, since it is a room of every level's MIQP
(to an L- or T-shaped fixed room, the MIQP counts the contact with its largest
rectangle only: conservative, the final check counts the whole polygon). Adjacencies
between two fixed rooms are left to the final check.

The answer then gets the fixed rooms' polygons exactly as given, the free rooms' walls
within `OUTPUT_SNAP` of them moved onto them, and the whole layout is checked again
against the problem as asked: the fixed rooms' own constraints (sizes, ratio, boundary
walls, positions) included. A problem the fixed rooms make impossible gets the usual
infeasibility report; its conflict names a fixed room by its polygon
(`rooms.<r>.fixed`), not by the size and corners that pin it.

The search takes the time limit times the share of free rooms (at least
`MIN_TIME_SHARE` of it): an edit of a plan with most rooms fixed comes back sooner.
When the pinned problem finds no layout, the edit's MIQP (`solver.pipeline.edit`),
which holds an L-shaped fixed room whole, gets the time left (`last_edit`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

from shapely.geometry import Polygon

from floorplan.models import (
    ConflictItem,
    ConflictSet,
    Infeasibility,
    Layout,
    Obstacle,
    Problem,
    Report,
    Termination,
)
from floorplan.solver.budget import default_time_limit
from floorplan.solver.events import EventSink, Phase, SolveEvent, StopFlag
from floorplan.solver.geometry import Box, domain_lines, rectangles_of, snap_rooms
from floorplan.solver.openings import connection_demands
from floorplan.solver.pipeline.assemble import drawn_rooms, remade_report
from floorplan.solver.pipeline.edit import EditResult, edit_applies, most_fixed, solve_edit
from floorplan.solver.pipeline.run import OUTPUT_SNAP
from floorplan.solver.pipeline.subdomains import SubdomainExecutor
from floorplan.solver.verify.checker import COVERAGE_GOAL, check_layout

#: The fields a pinned room's conflict items name: all of them its `fixed` polygon.
PINNED_FIELDS = frozenset({"min_size", "max_size", "target_size", "positions"})
#: The label of an obstacle standing for part of a fixed room that is not a rectangle.
FIXED_PART_LABEL = "fixed room {room}"

#: The search around fixed rooms takes the time limit times the share of free rooms,
#: at least this share: the fixed rooms cannot move, and the search that would try to
#: move them (level 1's neighbourhood search) would spend the rest for nothing.
MIN_TIME_SHARE = 0.5
#: The pinned path after an edit that found nothing gets at least this many seconds.
MIN_SECONDS = 1.0

Solver = Callable[..., Layout]


def has_fixed(problem: Problem) -> bool:
    """Whether some room of a single-floor `problem` is fixed."""
    return any(room.fixed is not None for room in problem.rooms)


def fixed_boxes(problem: Problem) -> dict[str, list[Box]]:
    """Room id -> the rectangles of its fixed polygon, largest first."""
    return {room.id: sorted(rectangles_of(Polygon(room.fixed)),
                            key=lambda b: -b.width * b.depth)
            for room in problem.rooms if room.fixed is not None}


def start_boxes(problem: Problem) -> dict[str, list[Box]]:
    """`options.start` as room id -> rectangles (empty without a start)."""
    return {room.id: [Box(r.x, r.y, r.x + r.width, r.y + r.depth) for r in room.rectangles]
            for room in problem.options.start or []}


def pinned_problem(problem: Problem) -> Problem:
    """`problem` with each fixed room held at its polygon's largest rectangle (exact
    size, two opposite corners to cover, one rectangle) and the rest of the polygon
    as obstacles; never partitioned into regions."""
    boxes = fixed_boxes(problem)
    rooms, obstacles = [], list(problem.obstacles)
    for room in problem.rooms:
        if room.id not in boxes:
            rooms.append(room)
            continue
        b, *rest = boxes[room.id]
        rooms.append(room.model_copy(update={
            "fixed": None, "min_size": (b.width, b.depth), "max_size": (b.width, b.depth),
            "target_size": (b.width, b.depth), "aspect_ratio": None,
            "positions": [(b.x0, b.y0), (b.x1, b.y1)], "boundary": [],
            "shape": "rectangle", "max_rects": 1, "soft": False,
        }))
        obstacles += [Obstacle(x=p.x0, y=p.y0, width=p.width, depth=p.depth,
                               label=FIXED_PART_LABEL.format(room=room.id)) for p in rest]
    options = problem.options.model_copy(update={"regions_above": 0, "start": None})
    # Between fixed rooms a contact is what it is: the final check judges it.
    adjacency = [a for a in problem.adjacency
                 if not all(n in boxes for n in (a.a, *a.partners))]
    return problem.model_copy(update={"rooms": rooms, "obstacles": obstacles,
                                      "adjacency": adjacency, "options": options})


def solve_fixed(
    problem: Problem,
    *,
    solve: Solver,
    on_event: EventSink | None = None,
    should_stop: StopFlag | None = None,
    subdomains: SubdomainExecutor | None = None,
    start: Mapping[str, list[Box]] | None = None,
) -> Layout:
    """Lay out the free rooms of `problem` around its fixed ones, then put the fixed
    rooms back exactly and check the whole layout. With most rooms fixed, the free ones
    are one small sub-domain first (`solver.pipeline.edit`); otherwise, or when that
    finds no valid layout, the pinned problem goes through `solve`, the dispatcher, in
    the time left. `start` warm-starts the free rooms of an edit."""
    started = time.monotonic()
    fixed = [room.id for room in problem.rooms if room.fixed is not None]
    if start is None:
        start = start_boxes(problem)
    limit = problem.options.time_limit or default_time_limit(len(problem.rooms))
    until = started + limit
    short: Layout | None = None  # the edit's valid layout short of the coverage goal
    if edit_applies(problem):
        kept = start_layout(problem, start, started)
        if kept is not None and time.monotonic() >= started + limit:
            # No time left to search (SCIP, given any, takes at least 0.05 s and may
            # or may not find something in it): the start that holds is the answer.
            _told(on_event, started, "edit: no time left to search; the start still "
                  "holds and is kept")
            _done(on_event, kept, started)
            return kept
        result = solve_edit(problem, fixed_boxes(problem), deadline=started + limit,
                            start=start, on_event=on_event, should_stop=should_stop)
        if result.rooms is not None:
            report = Report(coverage=0.0, uncovered_area=0.0, levels=result.levels,
                            termination=result.termination, valid=True)
            layout = fixed_layout(problem, result.rooms, report, started)
            stopped = should_stop is not None and should_stop()
            # An edit never answers worse than the start it was given, nor answers the
            # start back (SCIP may hand its warm start over as found) as something new.
            better = kept is None or layout.report.objective < kept.report.objective - 1e-9
            if better and (layout.report.valid or (stopped and kept is None)):
                if stopped or covers(layout) or most_fixed(problem):
                    _done(on_event, layout, started)
                    return layout
                # Few rooms fixed: the whole pipeline has room to do better; the
                # better of the two is the answer.
                short = layout
        if kept is not None:
            # The start still holds every constraint: it is the answer rather than seconds
            # more of the whole pipeline, which may end with nothing (or, its fixed L
            # rooms held by their largest rectangles, call a feasible edit infeasible).
            _told(on_event, started, f"edit: {result.status}, nothing better in the edit's "
                  "time; the start still holds and is kept")
            _done(on_event, kept, started)
            return kept
        limit -= time.monotonic() - started
        _told(on_event, started, f"edit: {result.status}, " + (
            "a valid layout short of the coverage goal; the whole pipeline around the "
            "fixed rooms, the better of the two kept" if short is not None else
            "no valid layout; the whole pipeline around the fixed rooms"))
    share = max(1 - len(fixed) / len(problem.rooms), MIN_TIME_SHARE)
    pinned = pinned_problem(problem).with_options(time_limit=max(limit * share, MIN_SECONDS))
    layout = solve(pinned, on_event=on_event, should_stop=should_stop, subdomains=subdomains)
    if short is not None:
        whole = relaid(problem, layout) if layout.rooms else None
        if whole is not None and _rank(whole) > _rank(short):
            return whole
        _told(on_event, started, "edit: the whole pipeline did no better; the edit's "
              "layout is the answer")
        _done(on_event, short, started)
        return short
    shaped = [r for r, boxes in fixed_boxes(problem).items() if len(boxes) > 1]
    if not layout.rooms and (shaped or layout.report.termination is not Termination.INFEASIBLE):
        edited = last_edit(problem, start, until, started, on_event, should_stop)
        if edited is not None:
            return edited
    if not layout.rooms:
        why = layout.report.infeasibility
        termination = layout.report.termination
        if why is not None:
            why = why.model_copy(update={
                "reason": f"{why.reason} (rooms fixed: {', '.join(fixed)}; each is held "
                "at its fixed polygon, by its size and two opposite corners)",
                "conflict": fixed_conflict(problem, why.conflict)})
        if termination is Termination.INFEASIBLE and shaped and why is not None and not (
                why.findings):
            # Held by its largest rectangle, an L-shaped fixed room offers its neighbours
            # less wall than it has: SCIP's proof holds for the pinned problem only.
            termination = Termination.NO_SOLUTION
            why = why.model_copy(update={"reason": f"{why.reason}; not proved for the "
                                 f"fixed rooms' own shapes ({', '.join(shaped)})"})
        return layout.model_copy(update={"report": layout.report.model_copy(
            update={"infeasibility": why, "termination": termination})})
    return relaid(problem, layout)


def covers(layout: Layout) -> bool:
    """Whether `layout` meets the coverage goal (`COVERAGE_GOAL` of the free floor)."""
    return layout.report.coverage >= COVERAGE_GOAL - 1e-9


def _rank(layout: Layout) -> tuple[bool, bool, float]:
    """Valid first, then covering the goal, then the lower Eq. 12."""
    return layout.report.valid, covers(layout), -(layout.report.objective or 0.0)


def last_edit(problem: Problem, start: Mapping[str, list[Box]], until: float, started: float,
              on_event: EventSink | None, should_stop: StopFlag | None) -> Layout | None:
    """The pinned path found no layout (unproved, or proved only for fixed rooms held
    by their largest rectangles): the edit's MIQP, which holds each fixed room whole,
    with all the time left until `until` (monotonic). Its layout when valid, else None."""
    if time.monotonic() >= until or (should_stop is not None and should_stop()):
        return None
    _told(on_event, started, "edit: the whole pipeline found no layout; the free rooms "
          "alone around the fixed ones, in the time left")
    result = solve_edit(problem, fixed_boxes(problem), deadline=until, start=start,
                        on_event=on_event, should_stop=should_stop,
                        seconds=until - time.monotonic(), first=True)
    layout = edit_layout(problem, result, started, result.termination)
    if layout is not None:
        _done(on_event, layout, started)
    return layout


def edit_layout(problem: Problem, result: EditResult, started: float,
                termination: Termination) -> Layout | None:
    """An edit's `result` as a layout of the whole `problem`, checked (`fixed_layout`);
    None when the edit found no rooms or its layout fails the checker."""
    if result.rooms is None:
        return None
    report = Report(coverage=0.0, uncovered_area=0.0, levels=result.levels,
                    termination=termination, valid=True)
    layout = fixed_layout(problem, result.rooms, report, started)
    return layout if layout.report.valid else None


def start_layout(problem: Problem, start: Mapping[str, list[Box]],
                 started: float) -> Layout | None:
    """The start's free rooms around the fixed ones, when every free room has a place in
    it and the whole layout passes the checker; else None."""
    free = [room.id for room in problem.rooms if room.fixed is None]
    if not free or not all(start.get(room_id) for room_id in free):
        return None
    report = Report(coverage=0.0, uncovered_area=0.0, termination=Termination.STALLED,
                    valid=True)
    layout = fixed_layout(problem, {r: start[r] for r in free}, report, started)
    return layout if layout.report.valid else None


def _told(on_event: EventSink | None, started: float, detail: str) -> None:
    """Say which way an edit went, as a level-1 event."""
    if on_event is not None:
        on_event(SolveEvent(phase=Phase.LEVEL, level=1, elapsed=time.monotonic() - started,
                            detail=detail))


def _done(on_event: EventSink | None, layout: Layout, started: float) -> None:
    if on_event is not None:
        on_event(SolveEvent(phase=Phase.DONE, level=layout.report.levels,
                            elapsed=time.monotonic() - started,
                            objective=layout.report.objective,
                            detail=f"coverage {layout.report.coverage:.1%}"))


def fixed_conflict(problem: Problem, conflict: ConflictSet | None) -> ConflictSet | None:
    """`conflict` of the pinned problem in the user's terms: the pinned size and corners
    of a fixed room become one item, its `fixed` polygon (``rooms.<r>.fixed``)."""
    if conflict is None:
        return None
    index = {room.id: r for r, room in enumerate(problem.rooms)}
    items: list[ConflictItem] = []
    for item in conflict.constraints:
        parts = item.path.split(".")
        room = problem.rooms[int(parts[1])] if parts[0] == "rooms" and len(parts) > 2 else None
        if room is None or room.fixed is None or parts[2] not in PINNED_FIELDS:
            items.append(item)
            continue
        path = f"rooms.{index[room.id]}.fixed"
        if any(i.path == path for i in items):
            continue
        items.append(ConflictItem(
            path=path, kind="fixed", rooms=[room.id], constraint=f"{room.id}.fixed",
            phrase=f"'{room.id}' is fixed at its polygon ({len(room.fixed or [])} vertices)"))
    return conflict.model_copy(update={
        "constraints": items,
        "explanation": f"{conflict.explanation} A fixed room's size and corners are those "
        "of its fixed polygon."})


def relaid(problem: Problem, layout: Layout) -> Layout:
    """`layout` of `pinned_problem(problem)` with the fixed rooms put back exactly, the
    walls near theirs snapped onto them, and the report made again for `problem`."""
    placed = {room.id: [Box.of(r) for r in room.rectangles] for room in layout.rooms}
    out = fixed_layout(problem, placed, layout.report)
    return layout.model_copy(update={"rooms": out.rooms, "doors": out.doors,
                                     "windows": out.windows, "report": out.report})


def fixed_layout(problem: Problem, placed: Mapping[str, list[Box]], report: Report,
                 started: float | None = None) -> Layout:
    """The layout of `problem` from the free rooms' rectangles `placed`: the fixed rooms
    exactly at their polygons, the walls near theirs snapped onto them, openings, and
    `report` made again for the whole problem (with the solve time since `started`)."""
    exact = fixed_boxes(problem)
    xs, ys = domain_lines(problem)
    xs = [*xs, *(v for boxes in exact.values() for b in boxes for v in (b.x0, b.x1))]
    ys = [*ys, *(v for boxes in exact.values() for b in boxes for v in (b.y0, b.y1))]
    rooms = snap_rooms({r: list(b) for r, b in placed.items() if r not in exact}, xs, ys,
                       OUTPUT_SNAP)
    rooms.update(exact)
    checked = connection_demands(problem)
    check = check_layout(checked, rooms)
    # The rooms and openings as the solve's own demands (doors) have them; the verdicts
    # for the problem asked.
    out, openings = drawn_rooms(checked, rooms)
    timed: dict[str, object] = {} if started is None else {
        "solve_time": time.monotonic() - started}
    before = report
    report = remade_report(problem, report, check, openings).model_copy(update=timed)
    constraints, valid = report.constraints, report.valid
    if before.valid and not valid:
        broken = sorted({r for c in constraints if not c.satisfied and not c.soft
                         for r in c.rooms})
        report = report.model_copy(update={
            "termination": Termination.NO_SOLUTION,
            "infeasibility": Infeasibility(
                reason="the layout around the fixed rooms breaks the hard constraints the "
                f"report marks unsatisfied (rooms {', '.join(broken)}): a fixed room's own "
                "constraints must hold on its fixed polygon"),
        })
    return Layout(name=problem.name, rooms=out, doors=openings.doors,
                  windows=openings.windows, report=report)

