"""Level 1 (Sec. 5.4): the first layout, by slicing, batches or the size-window
schedule, with extra rectangles when one per room cannot do; soft constraints priced
when nothing meets them all. The second search alongside it, when a pool is there, is
solver/pipeline/second_search.py's."""

from __future__ import annotations

import random
import time
from collections.abc import Mapping

from floorplan.models import ExtraRectangles, Infeasibility, Layout, Problem, Termination
from floorplan.solver.budget import first_pass_end
from floorplan.solver.events import Phase
from floorplan.solver.geometry import Box, Domain
from floorplan.solver.heuristics.construct import construct
from floorplan.solver.heuristics.level_one import (
    FIRST_BAND,
    level_one_spec,
    shape_allowance,
    target_bands,
    unfitting_targets,
    windows_to_try,
    wing_order,
    wings_wanted,
)
from floorplan.solver.heuristics.neighbourhood import NEIGHBOURHOOD_SIZE
from floorplan.solver.heuristics.slicing import (
    note_slicing,
    slicing_applies,
    slicing_has_demands,
    slicing_known_to_fail,
    slicing_layout,
)
from floorplan.solver.heuristics.variety import pull_to_anchors
from floorplan.solver.miqp.formulation import active_families, build_level
from floorplan.solver.miqp.objective import e_band_shortfall
from floorplan.solver.miqp.scip_run import LevelResult, LevelStatus
from floorplan.solver.pipeline.assemble import explained, no_layout
from floorplan.solver.pipeline.hierarchy import Piece
from floorplan.solver.pipeline.improve import improve_level_one
from floorplan.solver.pipeline.run import Run, layout_objective
from floorplan.solver.soft import has_soft
from floorplan.solver.verify.precheck import find_impossibilities

#: Share of level 1's time one feasibility attempt of the relaxation schedule may use.
ATTEMPT_SHARE = 0.5
#: After this many size windows proved infeasible, `WINGS_SHARE` of the first layout's
#: time is kept for rooms of two rectangles (`_with_wings`).
REFUTED_BEFORE_WINGS = 3
WINGS_SHARE = 0.5
#: Share of the time left for one rectangle per room the probe of the user's bounds
#: (`_one_rectangle_probe`) may use.
PROBE_SHARE = 0.5
#: Above this many rooms the first layout is built in batches (solver/heuristics/construct.py):
#: one feasibility MILP of all rooms rarely finds anything in time.
CONSTRUCT_ABOVE = 20
#: Share of level 1's time a row plan honouring adjacency and boundary demands may take
#: (solver/heuristics/row_search.py): found in tens of milliseconds when rows can hold them.
SLICE_DEMANDS_SHARE = 0.06
#: Share of level 1's time the improvement of a late first layout gets
#: (`solver.budget.LATE_FIRST_FACTOR`).
LATE_IMPROVE_SHARE = 0.25
#: With soft constraints, the share of level 1's time the search for a layout meeting
#: every constraint may use before the soft model takes over.
STRICT_FIRST_SHARE = 0.5


def first_level(
    run: Run, domain: Domain, deadline: float
) -> tuple[list[Piece] | None, Layout | None]:
    """Level 1 until `deadline`: the pieces of the first layout, improved, or the
    report of why there is none."""
    problem = run.problem
    if not has_soft(problem):
        # Nothing else needs the time when there is no first layout: the search for
        # one may go on until the solve's end (SCIP's check of the answer included),
        # and under the default limit (a late allowance) as long as under `late_limit`.
        first_by = max(deadline, run.judge_end or run.end)
        if run.late_by:
            first_by = max(first_by, first_pass_end(run.started, len(problem.rooms)))
        pieces, failure = _level_one(run, domain, deadline, first_by=first_by)
        if (pieces is None and failure is not None and run.late_by - time.monotonic() > 0.1
                and failure.report.termination is Termination.NO_SOLUTION):
            # The late allowance (`solver.budget.LATE_FIRST_FACTOR`): the schedule again,
            # each attempt with its share of the longer time, where a search that was
            # near its layout goes on to it.
            run.emit(Phase.RELAXATION, detail="no first layout within the time limit: "
                     "searching on (the default limit's late allowance)")
            pieces, failure = _level_one(run, domain, deadline, first_by=run.late_by)
        return pieces, failure
    # A layout meeting every constraint, soft ones too, is looked for first (no price
    # per metre makes a violating layout reliably lose to it); the soft model takes
    # over when there is none, or none found in its share of the time (docs/method.md,
    # 'Soft constraints').
    pieces, failure = None, None
    if not find_impossibilities(problem, domain, ignore_soft=False):
        pieces, failure = _level_one(
            run, domain, deadline, explain=False,
            first_by=run.started + (deadline - run.started) * STRICT_FIRST_SHARE)
    if pieces is None and not run.stopped():
        pieces, failure = _soft_level_one(run, domain, deadline)
    return pieces, failure


def _level_one(
    run: Run, domain: Domain, deadline: float, *, first_by: float | None = None,
    explain: bool = True,
) -> tuple[list[Piece] | None, Layout | None]:
    """Sec. 5.4: find a first layout with size bounds at target +-10 %, widening by 10 %
    until one is found (by `first_by`, else by `deadline`); then improve it under the
    user's own bounds (Eq. 12) until `deadline`. Without `explain`, an infeasible
    problem's answer has no conflict search."""
    problem = run.problem
    improve_by, deadline = deadline, first_by or deadline
    first: LevelResult | None = None
    proven_infeasible = False
    large = len(problem.rooms) > CONSTRUCT_ABOVE
    run.wings = wings_wanted(problem)
    run.extra = [ExtraRectangles(room=room_id, rectangles=count + 1, reason="asked")
                 for room_id, count in run.wings.items()]
    # (Not for sizes alone: slicing's rows cover the floor at once, with rectangles;
    # the reshaping makes the L later.)
    unfitting = unfitting_targets(problem, domain) if slicing_has_demands(problem) else []
    for room_id in unfitting:
        if room_id not in run.wings:
            run.wings[room_id] = 1
            run.extra.append(ExtraRectangles(
                room=room_id, rectangles=2,
                reason="its target size fits nowhere in the floor as one rectangle"))
    # Keep time for extra rectangles when one rectangle per room is not enough: a brief
    # extracted from a plan with L-shaped rooms often has no one-rectangle layout, and
    # SCIP may not prove it before the windows have used the time.
    may_widen = any(shape_allowance(r) > 1 + run.wings.get(r.id, 0) for r in problem.rooms)
    single_by = deadline
    refuted = 0
    fallback: LevelResult | None = None  # a layout of the user's bounds, found by the probe
    # Up to NEIGHBOURHOOD_SIZE rooms the improvement solves the whole MIQP outright from
    # any first layout, and the window model finds one in tens of milliseconds: rows
    # would only cost time (apartment-5: 0.3 s of a 0.6 s solve, finding none).
    small = len(problem.rooms) <= NEIGHBOURHOOD_SIZE
    if (slicing_applies(problem) and not small and not run.wings
            and not slicing_known_to_fail(problem)):
        # Rows always exist for sizes alone; with demands they may not, so the MIQP
        # keeps most of the time.
        share = SLICE_DEMANDS_SHARE if slicing_has_demands(problem) else 0.5
        first = _slice(run, domain, time.monotonic() + (deadline - time.monotonic()) * share)
    if large and first is None:
        first = _construct(run, domain, time.monotonic() + (deadline - time.monotonic()) / 2)
    for attempt, window in enumerate([] if first is not None else windows_to_try(problem)):
        left = single_by - time.monotonic()
        if left <= 0.05 or run.stopped():
            break
        spec = level_one_spec(problem, domain, window=window, wings=run.wings)
        lm = build_level(spec, feasibility=True)
        # After a window that gave nothing, SCIP looks harder for a first layout
        # (docs/method.md, 'Rooms of several rectangles'); the first attempt keeps the
        # settings that serve the paper's cases best.
        lm.aggressive = attempt > 0
        if window is None:  # no window held: the user's bounds, sizes pulled to the targets
            e_band_shortfall(lm, target_bands(problem, domain, FIRST_BAND))
        if problem.options.diverse:  # the seed's arrangement
            pull_to_anchors(lm, problem.options.seed)
        share = left * (ATTEMPT_SHARE if window is not None or may_widen else 1.0)
        result = run.run(lm, share)
        label = "user bounds" if window is None else f"target ±{window:.0%}"
        run.relaxations.append(f"{label}: {result.status}")
        run.emit(Phase.RELAXATION, detail=f"size bounds {label}: {result.status}")
        if result.rects is not None:
            first, run.window = result, window
            break
        proven_infeasible = window is None and result.status is LevelStatus.INFEASIBLE
        refuted += result.status is LevelStatus.INFEASIBLE
        # On the window whose proof is the third, so once: `refuted` stays at its count
        # while the wider windows end without a proof (else the probe would come after
        # each of them, the wings' time halved each time: bench/NOTES.md, 'Fillers with
        # a known side, one probe').
        if (refuted == REFUTED_BEFORE_WINGS and window is not None
                and result.status is LevelStatus.INFEASIBLE):
            # Windows proved empty one after another: one rectangle per room may well
            # be impossible (a brief extracted from a plan with L-shaped rooms), and
            # SCIP may not prove it before the wider windows have used the time.
            if may_widen:
                single_by = deadline - (deadline - time.monotonic()) * WINGS_SHARE
            probe = _one_rectangle_probe(run, domain, single_by)
            if probe.status is LevelStatus.INFEASIBLE:
                proven_infeasible = True  # for every window: each lies within the bounds
                break
            if probe.rects is not None:
                fallback = probe
    if first is None and fallback is not None:
        first, run.window = fallback, None
    if first is None and not proven_infeasible and not large:
        first = _construct(run, domain, single_by)
    # What SCIP proved holds for the shapes it was given: the verdict is "infeasible"
    # only when those are every shape the rooms may take (`max_rects`).
    proven_for_all = proven_infeasible and every_shape_tried(problem, run.wings)
    if first is None and may_widen:
        first, proven_winged = _with_wings(run, domain, deadline, why=(
            "one rectangle per room is infeasible (proved by SCIP)" if proven_infeasible
            else "no one-rectangle-per-room layout was found in its share of the time"))
        proven_for_all = proven_for_all or (first is None and proven_winged
                                            and every_shape_tried(problem, run.tried_wings))
    if first is None:
        return None, no_first_layout(run, domain, proven_infeasible, proven_for_all,
                                      explain)
    assert first.rects is not None
    run.incumbent(domain, run.by_room(domain, first.rects))
    if (late := time.monotonic() - improve_by) > 0 and run.late_by:
        # A late first layout (`FloorBudget.late_by`): its improvement gets a share of
        # level 1's time, as the later stages keep theirs.
        improve_by = min(run.late_by,
                         improve_by + late + LATE_IMPROVE_SHARE * (improve_by - run.started))
    boxes = improve_level_one(run, domain, first.rects, improve_by)
    return run.pieces(domain, boxes), None


def _one_rectangle_probe(run: Run, domain: Domain, deadline: float) -> LevelResult:
    """Whether one rectangle per room can meet the user's own bounds at all: a pure
    feasibility model, given `PROBE_SHARE` of the time until `deadline`. After windows
    proved empty one after another, a proof here stops the schedule at once (every
    window lies within the user's bounds) where proving the wider windows one by one
    used half the time (docs/method.md, 'Rooms of several rectangles'); a layout found
    is kept in case the narrower windows find none."""
    lm = build_level(level_one_spec(run.problem, domain, window=None, wings=run.wings),
                     feasibility=True)
    lm.aggressive = True
    result = run.run(lm, max(0.0, deadline - time.monotonic()) * PROBE_SHARE)
    run.relaxations.append(f"user bounds, feasibility only: {result.status}")
    run.emit(Phase.RELAXATION, detail=f"size bounds user bounds, feasibility only: "
                                      f"{result.status}")
    return result


def every_shape_tried(problem: Problem, wings: Mapping[str, int]) -> bool:
    """Whether rooms of one rectangle plus `wings` are every shape the rooms may take
    (`shape_allowance`)."""
    return all(shape_allowance(room) <= 1 + wings.get(room.id, 0) for room in problem.rooms)


def no_first_layout(run: Run, domain: Domain, proven_infeasible: bool,
                     proven_for_all: bool, explain: bool) -> Layout:
    """The answer when level 1 found nothing (docs/method.md, 'Verdicts'): infeasible
    only when SCIP proved it for every shape the rooms may take (with the constraints
    that cannot hold together, if `explain`); else interrupted or out of time, saying
    what was proved for the shapes tried."""
    problem = run.problem
    spec = level_one_spec(problem, domain, window=None, wings=run.wings)
    if proven_for_all:
        shapes = ("single-rectangle" if all(r.max_rects == 1 for r in problem.rooms)
                  else "allowed (max_rects)")
        why = Infeasibility(
            reason=f"SCIP proved that no layout of {shapes} rooms satisfies the constraints",
            active_families=active_families(spec), relaxations_tried=run.relaxations)
        if explain:
            why = explained(run, domain, why)
        return no_layout(run, Termination.INFEASIBLE, why)
    if run.stopped():
        termination = Termination.INTERRUPTED
        reason = "stopped on request before any layout was found"
    elif proven_infeasible:
        termination = Termination.NO_SOLUTION
        reason = ("SCIP proved that no layout of one rectangle per room exists; none with "
                  "L- or T-shaped rooms was found within the time limit, so feasibility is "
                  "unknown")
    else:
        termination = Termination.NO_SOLUTION
        reason = "no layout was found within the time limit; feasibility is unknown"
    return no_layout(run, termination, Infeasibility(
        reason=reason, active_families=active_families(spec),
        relaxations_tried=run.relaxations))


def _soft_level_one(
    run: Run, domain: Domain, deadline: float
) -> tuple[list[Piece] | None, Layout | None]:
    """Soft constraints (docs/method.md, 'Soft constraints'): no layout meeting every
    constraint was found, so the soft ones get slacks priced per metre. The first
    layout minimises the total violation alone (a MILP; above `CONSTRUCT_ABOVE` rooms
    built in batches); then Eq. 12 plus that price is minimised as for any problem."""
    problem = run.problem
    run.soft = True
    spec = level_one_spec(problem, domain, window=None, wings=run.wings, soft=True)
    left = deadline - time.monotonic()
    rects: dict[str, Box] | None = None
    status = LevelStatus.NO_SOLUTION
    if len(problem.rooms) > CONSTRUCT_ABOVE and not run.wings:
        rects = construct(spec, deadline=time.monotonic() + left * ATTEMPT_SHARE,
                          rng=random.Random(problem.options.seed),
                          step=lambda model, limit: run.run(model, limit))
    if rects is None and deadline - time.monotonic() > 0.05 and not run.stopped():
        result = run.run(build_level(spec, feasibility=True),
                         (deadline - time.monotonic()) * ATTEMPT_SHARE)
        rects, status = result.rects, result.status
    outcome = "found" if rects is not None else status.value
    run.relaxations.append(f"user bounds, soft constraints priced: {outcome}")
    run.emit(Phase.RELAXATION, detail=f"soft constraints priced: {outcome}")
    if rects is None:
        if status is LevelStatus.INFEASIBLE and every_shape_tried(problem, run.wings):
            why = Infeasibility(
                reason="SCIP proved that no single-rectangle layout satisfies the hard "
                "constraints (inside, no overlap, obstacles and those not soft)",
                active_families=active_families(spec), relaxations_tried=run.relaxations)
            return None, no_layout(run, Termination.INFEASIBLE, explained(run, domain, why))
        termination = Termination.INTERRUPTED if run.stopped() else Termination.NO_SOLUTION
        return None, no_layout(run, termination, Infeasibility(
            reason="stopped on request before any layout was found" if run.stopped() else
            "SCIP proved that no layout of one rectangle per room meets the hard "
            "constraints; rooms of other shapes were not tried, so feasibility is unknown"
            if status is LevelStatus.INFEASIBLE else
            "no layout was found within the time limit; feasibility is unknown",
            active_families=active_families(spec), relaxations_tried=run.relaxations))
    run.incumbent(domain, run.by_room(domain, rects))
    boxes = improve_level_one(run, domain, rects, deadline)
    return run.pieces(domain, boxes), None


def _with_wings(run: Run, domain: Domain, deadline: float, why: str
                ) -> tuple[LevelResult | None, bool]:
    """When one rectangle per room fails, let the largest rooms (`wing_order`) start as
    two rectangles (an L or T), one more room at each attempt, doubling
    (docs/method.md, 'Rooms of several rectangles').
    Returns the first layout found, or None and whether SCIP proved the last attempt
    (every room of two rectangles or more, `run.tried_wings`) infeasible."""
    problem = run.problem
    may = {room.id: shape_allowance(room) - 1 for room in problem.rooms}
    order = [r for r in wing_order(problem) if r not in run.wings and may[r] > 0]
    count = 1
    while order and not run.stopped():
        left = deadline - time.monotonic()
        if left <= 0.05:
            return None, False
        chosen = order[:count]
        last = count >= len(order)
        # The last attempt gives every room all the rectangles it may have: what SCIP
        # proves of it holds for every shape.
        wings = run.wings | ({r: may[r] for r in chosen} if last else dict.fromkeys(chosen, 1))
        spec = level_one_spec(problem, domain, window=None, wings=wings)
        lm = build_level(spec, feasibility=True)
        lm.aggressive = True  # one rectangle per room gave nothing
        result = run.run(lm, left if last else left * ATTEMPT_SHARE)
        label = (f"user bounds, every room of up to {max(may.values()) + 1} rectangles"
                 if last and len(chosen) == len(problem.rooms)
                 else f"user bounds, {', '.join(chosen)} as two rectangles")
        run.relaxations.append(f"{label}: {result.status}")
        run.emit(Phase.RELAXATION, detail=f"size bounds {label}: {result.status}")
        if result.rects is not None:
            run.wings = wings
            run.extra += [ExtraRectangles(room=r, rectangles=1 + wings[r], reason=why)
                          for r in chosen]
            return result, False
        if last:
            run.tried_wings = wings
            return None, result.status is LevelStatus.INFEASIBLE
        count *= 2
    return None, False


def _slice(run: Run, domain: Domain, deadline: float) -> LevelResult | None:
    """A first layout of rows of rooms filling the floor (solver/heuristics/slicing.py)."""
    started = time.monotonic()
    rects = slicing_layout(run.problem, domain, deadline=deadline,
                           seed=run.problem.options.seed)
    note_slicing(run.problem, rects is not None)
    outcome = "found" if rects is not None else "nothing found"
    run.relaxations.append(f"user bounds, sliced into rows: {outcome}")
    run.emit(Phase.RELAXATION, detail=f"size bounds user bounds, sliced into rows: {outcome}")
    if rects is None:
        return None
    return LevelResult(LevelStatus.FEASIBLE, rects, layout_objective(
        run.problem, domain, {k: [b] for k, b in rects.items()}), None,
        time.monotonic() - started)


def _construct(run: Run, domain: Domain, deadline: float) -> LevelResult | None:
    """A first layout built a batch of rooms at a time (solver/heuristics/construct.py)."""
    if deadline - time.monotonic() <= 0.1 or run.stopped() or run.wings:
        return None
    spec = level_one_spec(run.problem, domain, window=None)
    rects = construct(spec, deadline=deadline, rng=random.Random(run.problem.options.seed),
                      step=lambda model, limit: run.run(model, limit))
    outcome = "found" if rects is not None else "nothing found"
    run.relaxations.append(f"user bounds, built in batches: {outcome}")
    run.emit(Phase.RELAXATION, detail=f"size bounds user bounds, built in batches: {outcome}")
    if rects is None:
        return None
    return LevelResult(LevelStatus.FEASIBLE, rects, None, None, 0.0)
