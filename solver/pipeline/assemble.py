"""The answer of a single-floor solve: the layout with its polygons, openings and
checked report; the report of why there is none; drafts of incumbents for progress."""

from __future__ import annotations

import time
from collections.abc import Mapping

import shapely

from floorplan.models import (
    ConstraintCheck,
    Infeasibility,
    Layout,
    Problem,
    Report,
    RoomLayout,
    Termination,
    Weights,
)
from floorplan.models.storeys import draft_floor, floor_view
from floorplan.solver.events import Phase
from floorplan.solver.geometry import (
    Box,
    Domain,
    GeometryError,
    domain_lines,
    polygon_coords,
    room_polygon,
    snap_rooms,
    wall_moves,
    walls_moved,
)
from floorplan.solver.openings import Openings, add_openings
from floorplan.solver.pipeline.hierarchy import Piece, room_boxes
from floorplan.solver.pipeline.judge import judged
from floorplan.solver.pipeline.run import OUTPUT_SNAP, Run
from floorplan.solver.soft import hard_part
from floorplan.solver.verify.checker import (
    DEFAULT_TOL,
    CheckResult,
    check_layout,
    place_rooms,
    size_error,
)
from floorplan.solver.verify.conflicts import find_conflict

#: Walls of the answer closer than this (metres) are put on one line: a jog thinner than
#: a wall is where the search's walls happened to stop, not a design (docs/method.md,
#: "The steps", step 7).
STRAIGHTEN_TOLERANCE = 0.1
#: The straightened layout is the answer when it passes the checker, covers as much
#: and its Eq. 12 is at most this share above the layout's.
STRAIGHTEN_COST = 0.02
#: When lining up every run of walls at once fails, at most this many runs are tried
#: one at a time (a check each).
STRAIGHTEN_RUNS = 12


#: A solve that ended this many seconds before its end ended on its own (stalled).
END_SLACK = 0.05
#: Two layouts are the same answer when no wall of one lies farther than this (metres)
#: from the other's: the output's snapping (`OUTPUT_SNAP`) moves walls less.
SAME_LAYOUT_TOL = 1e-3


def termination(run: Run, rooms: Mapping[str, list[Box]]) -> tuple[Termination, float | None]:
    """Why the solve of the layout `rooms` ended, and SCIP's bound on its Eq. 12 when the
    layout is SCIP's answer for the whole floor's model: `optimal` only when SCIP proved
    this very layout optimal; a layout changed after SCIP's last word (refinement levels,
    heuristics) ended `stalled` when the solve ended before its time limit, else
    `timelimit`."""
    if run.stopped():
        return Termination.INTERRUPTED, None
    answer, bound = run.scip_answer, None
    if answer is not None and same_layout(answer.rooms, rooms):
        if answer.optimal:
            return Termination.OPTIMAL, answer.bound
        bound = answer.bound
    if time.monotonic() < (run.judge_end or run.end) - END_SLACK:
        return Termination.STALLED, bound
    return Termination.TIME_LIMIT, bound


def same_layout(a: Mapping[str, list[Box]], b: Mapping[str, list[Box]]) -> bool:
    """Whether two layouts have the same rooms of the same rectangles, walls within
    `SAME_LAYOUT_TOL` (rectangles compared in order of their corners)."""
    if a.keys() != b.keys():
        return False
    for room, boxes in a.items():
        mine = sorted((r.x0, r.y0, r.x1, r.y1) for r in boxes)
        theirs = sorted((r.x0, r.y0, r.x1, r.y1) for r in b[room])
        if len(mine) != len(theirs) or any(
                abs(p - q) > SAME_LAYOUT_TOL for x, y in zip(mine, theirs, strict=True)
                for p, q in zip(x, y, strict=True)):
            return False
    return True


def final_layout(run: Run, domain: Domain, pieces: list[Piece], levels: int) -> Layout:
    problem = run.problem
    # Walls SCIP placed 1e-7 apart become exactly shared, as a CAD user expects.
    rooms = snap_rooms(room_boxes(pieces), *domain_lines(problem), OUTPUT_SNAP)
    check = check_layout(problem, rooms)
    if not check.valid and (passing := run.passing_best()) is not None:
        # A layout breaking a hard constraint is never the answer when a covering
        # incumbent that passes was found (docs/method.md, "The steps", step 7).
        rooms, check = passing
    rooms, check = straight_walls(problem, rooms, check)
    rooms, check = _judged(run, domain, rooms, check)
    out, openings = drawn_rooms(problem, rooms)
    constraints, valid = with_circulation(problem, check, openings)
    (ended, bound), why = termination(run, rooms), None
    if not valid and ended is not Termination.INTERRUPTED:
        # A layout breaking a hard constraint is no answer; it is kept as a diagnostic
        # of how near the search came.
        ended, why = Termination.NO_SOLUTION, Infeasibility(
            reason="no layout meeting every hard constraint was found within the time "
            "limit; the rooms given are the best one found, which breaks the constraints "
            "the report marks unsatisfied, as a diagnostic",
            relaxations_tried=run.relaxations)
    size_errors, w = check.size_error, problem.weights
    if run.asked is not None and problem.options.diverse:
        # The search aimed at sizes the seed drew, under its own weights
        # (solver/heuristics/variety.py); the layout is the brief's, measured against the
        # brief's own targets and weights.
        size_errors = size_error(run.asked, place_rooms(run.asked, rooms, DEFAULT_TOL))
        w = run.asked.weights
    violations = [c for c in constraints if c.soft and not c.satisfied]
    shortfall = sum(c.shortfall for c in violations)
    objective = _objective(w, check.uncovered_area, size_errors, shortfall)
    report = Report(
        coverage=check.coverage, uncovered_area=check.uncovered_area,
        constraints=constraints, size_error=size_errors,
        objective=objective, bound=bound, gap=_gap(objective, bound), levels=levels,
        solve_time=run.elapsed(),
        termination=ended, valid=valid, infeasibility=why, circulation=openings.circulation,
        relaxation=run.window, extra_rectangles=run.extra,
        violations=violations, total_shortfall=round(shortfall, 6),
    )
    if not same_layout(run.announced or {}, rooms):
        # The last incumbent announced is the layout returned.
        run.emit(Phase.INCUMBENT, rooms=rooms, objective=objective, dual_bound=bound)
    run.emit(Phase.DONE, objective=objective, detail=f"coverage {check.coverage:.1%}")
    return Layout(name=problem.name, rooms=out, doors=openings.doors, windows=openings.windows,
                  report=report)


def _judged(run: Run, domain: Domain, rooms: dict[str, list[Box]], check: CheckResult
            ) -> tuple[dict[str, list[Box]], CheckResult]:
    """The valid layout `rooms` as SCIP answers it in the whole floor's MIQP
    (solver/pipeline/judge.py), unless SCIP already answered with it, the solve was
    stopped, or SCIP's answer does not pass the checker once snapped."""
    answer = run.scip_answer
    if not check.valid or run.stopped() or (answer is not None
                                             and same_layout(answer.rooms, rooms)):
        return rooms, check
    problem = run.problem
    polished = judged(run, domain, rooms, run.judge_end or run.end)
    if polished is rooms:
        return rooms, check
    snapped = snap_rooms(polished, *domain_lines(problem), OUTPUT_SNAP)
    again = check_layout(problem, snapped)
    if again.valid and again.coverage >= check.coverage - 1e-9:
        return snapped, again
    return rooms, check


def with_rooms(problem: Problem, layout: Layout, rooms: dict[str, list[Box]],
               check: CheckResult) -> Layout:
    """`layout` (the answer of `problem`, single floor) with its rooms moved to `rooms`,
    checked as `check`: polygons, doors, windows and the report's verdicts drawn anew,
    its termination and solve record kept (solver/pipeline/spread.py)."""
    out, openings = drawn_rooms(problem, rooms)
    return layout.model_copy(update={
        "rooms": out, "doors": openings.doors, "windows": openings.windows,
        "report": remade_report(problem, layout.report, check, openings)})


def remade_report(problem: Problem, report: Report, check: CheckResult,
                  openings: Openings) -> Report:
    """`report` with the verdicts of `check` (and of the circulation through
    `openings`), coverage, size errors and Eq. 12 made again for `problem`; how the
    solve ran and ended is kept."""
    constraints, valid = with_circulation(problem, check, openings)
    violations = [c for c in constraints if c.soft and not c.satisfied]
    shortfall = sum(c.shortfall for c in violations)
    return report.model_copy(update={
        "coverage": check.coverage, "uncovered_area": check.uncovered_area,
        "constraints": constraints, "size_error": check.size_error,
        "objective": _objective(problem.weights, check.uncovered_area, check.size_error,
                                shortfall),
        "valid": valid, "circulation": openings.circulation, "violations": violations,
        "total_shortfall": round(shortfall, 6)})


def drawn_rooms(problem: Problem, rooms: dict[str, list[Box]]
                 ) -> tuple[list[RoomLayout], Openings]:
    """The rooms of the answer as polygons, with the doors and windows between them."""
    polygons = {room.id: outline_of(rooms[room.id]) for room in problem.rooms}
    out = [
        RoomLayout(id=room.id, type=room.type, polygon=polygon_coords(polygons[room.id]),
                   rectangles=[b.to_rect() for b in rooms[room.id]],
                   area=round(float(polygons[room.id].area), 6))
        for room in problem.rooms
    ]
    return out, add_openings(problem, polygons)


def with_circulation(problem: Problem, check: CheckResult, openings: Openings
                      ) -> tuple[list[ConstraintCheck], bool]:
    """The checked constraints and verdict, with `options.require_connected`'s own check
    that every room is reachable through the doors."""
    constraints, valid = check.constraints, check.valid
    if problem.options.require_connected:
        connected = openings.circulation is not None and openings.circulation.reachable
        unreachable = openings.circulation.unreachable if openings.circulation else []
        constraints = [*constraints, ConstraintCheck(
            kind="circulation", rooms=unreachable, satisfied=connected,
            detail="every room reachable from the entrance" if connected else
            ("no entrance to start from" if openings.circulation is None else
             f"unreachable: {', '.join(unreachable)}"),
        )]
        if not problem.options.strict:
            # Soft, like the adjacencies require_connected added, which carry the shortfall.
            constraints[-1] = constraints[-1].model_copy(update={"soft": True})
        valid = valid and (connected or not problem.options.strict)
    return constraints, valid


def straight_walls(problem: Problem, rooms: dict[str, list[Box]], check: CheckResult
                   ) -> tuple[dict[str, list[Box]], CheckResult]:
    """A valid layout with its walls less than `STRAIGHTEN_TOLERANCE` apart lined up
    (`wall_moves`; the outline's and fixed rooms' walls stay), with its check: all of
    them at once when that stays valid, covers as much and costs at most
    `STRAIGHTEN_COST` of Eq. 12, else each run of walls on its own that does (a room at
    its maximum size keeps its jog, the others go). Slivers of rooms a few centimetres
    wide go with their jogs."""
    if not check.valid:
        return rooms, check
    xs, ys = domain_lines(problem)
    for room in problem.rooms:
        xs += [x for x, _ in room.fixed or []]
        ys += [y for _, y in room.fixed or []]
    moves = wall_moves(rooms, xs, ys, STRAIGHTEN_TOLERANCE)
    bound = _eq12(problem, check) * (1 + STRAIGHTEN_COST) + 1e-9

    def passing(kept: list[tuple[int, dict[float, float]]]
                ) -> tuple[dict[str, list[Box]], CheckResult] | None:
        lined = walls_moved(rooms, kept)
        again = check_layout(problem, lined)
        if again.valid and again.coverage >= check.coverage - 1e-9 and _eq12(
                problem, again) <= bound:
            return lined, again
        return None

    if not moves:
        return rooms, check
    if (every := passing(moves)) is not None:
        return every
    best: tuple[dict[str, list[Box]], CheckResult] = (rooms, check)
    kept: list[tuple[int, dict[float, float]]] = []
    for move in moves[:STRAIGHTEN_RUNS]:
        if (found := passing([*kept, move])) is not None:
            kept.append(move)
            best = found
    return best


def _eq12(problem: Problem, check: CheckResult) -> float:
    """Eq. 12 of a checked layout, soft constraints' shortfall priced."""
    shortfall = sum(c.shortfall for c in check.constraints if c.soft and not c.satisfied)
    return _objective(problem.weights, check.uncovered_area, check.size_error, shortfall)


def _objective(w: Weights, uncovered: float, size_errors: Mapping[str, float],
               shortfall: float) -> float:
    """Eq. 12 as the report gives it: lambda_cover * uncovered area + lambda_size * E_size,
    plus the soft constraints' shortfall at lambda_violation."""
    return w.cover * uncovered + w.size * sum(size_errors.values()) + w.violation * shortfall


def outline_of(boxes: list[Box]) -> shapely.Polygon:
    """A room's polygon. Rectangles that do not form one polygon are a failed
    'connected' check in the report, never an exception: the largest part stands for
    the room's outline, and `rectangles` still lists every piece."""
    try:
        return room_polygon(boxes)
    except GeometryError:
        union = shapely.union_all([b.to_polygon() for b in boxes])
        parts = list(getattr(union, "geoms", [union]))
        return shapely.orient_polygons(max(parts, key=lambda g: g.area))


def draft_layout(problem: Problem, rooms: dict[str, list[Box]], objective: float | None,
                 floor: str = "") -> Layout:
    """An incumbent as a layout for progress displays: polygons and coverage, no check
    (`termination: in_progress`, `valid: false` until the solve ends). In a building of
    several storeys, `floor` names the floor the incumbent is of (`SolveEvent.floor`)."""
    if problem.floors is not None and floor:
        return draft_floor(problem, floor, draft_layout(floor_view(problem, floor), rooms,
                                                        objective))
    domain_free = problem.free_area()
    out = []
    for room in problem.rooms:
        boxes = rooms.get(room.id, [])
        if not boxes:
            continue
        polygon = outline_of(boxes)
        area = shapely.union_all([b.to_polygon() for b in boxes]).area
        out.append(RoomLayout(
            id=room.id, type=room.type, polygon=polygon_coords(polygon),
            rectangles=[b.to_rect() for b in boxes], area=round(float(area), 6),
        ))
    covered = shapely.union_all([b.to_polygon() for boxes in rooms.values() for b in boxes])
    cover = float(domain_free.intersection(covered).area)
    report = Report(coverage=cover / domain_free.area if domain_free.area else 1.0,
                    uncovered_area=float(domain_free.area) - cover, objective=objective,
                    termination=Termination.IN_PROGRESS, valid=False)
    return Layout(name=problem.name, rooms=out, report=report)


def explained(run: Run, domain: Domain, why: Infeasibility) -> Infeasibility:
    """`why` with a small set of the user's constraints that cannot hold together,
    searched in the time the solve has left (solver/verify/conflicts.py); soft constraints
    never are among them."""
    conflict = find_conflict(hard_part(run.asked or run.problem), domain,
                             deadline=max(run.deadline, run.end), solved=hard_part(run.problem),
                             should_stop=run.should_stop)
    if conflict is not None:
        run.emit(Phase.CONFLICT, detail=f"{len(conflict.constraints)} constraints cannot "
                 f"hold together{'' if conflict.minimal else ' (perhaps not minimal)'}")
    return why.model_copy(update={"conflict": conflict})


def no_layout(run: Run, termination: Termination, why: Infeasibility) -> Layout:
    report = Report(coverage=0.0, uncovered_area=0.0, termination=termination, valid=False,
                    infeasibility=why, solve_time=run.elapsed())
    run.emit(Phase.DONE, detail=why.reason)
    return Layout(name=run.problem.name, report=report)


def _gap(objective: float | None, bound: float | None) -> float | None:
    """The relative gap between the layout's Eq. 12 and SCIP's bound on it."""
    if objective is None or bound is None:
        return None
    return max(objective - bound, 0.0) / max(abs(objective), 1e-9)
