"""One floor's solve: demands, prechecks, level 1, the hierarchy, the last gaps, the
reshaping, SCIP's check of the answer and the independent check.

The stages' shares of the time limit are `solver.budget.FloorBudget`'s table; each
stage ends early when it stalls (`Run.ending`), and a level 1 that SCIP proves optimal
and covering ends the solve. A search that finds no first layout may go on to the end.
"""

from __future__ import annotations

import math
import time

from floorplan.models import Infeasibility, Layout, Problem, Termination
from floorplan.models.options import REDRAW_SEED_STEP as WHOLE_REDRAW_SEED_STEP
from floorplan.solver.budget import FloorBudget, default_time_limit
from floorplan.solver.events import EventSink, Phase, SolveEvent, StopFlag
from floorplan.solver.geometry import Domain, make_domain
from floorplan.solver.heuristics.variety import (
    REDRAW_MIN_SHARE,
    REDRAW_SEED_STEP,
    REDRAWS,
    diverse_problem,
)
from floorplan.solver.openings import connection_demands
from floorplan.solver.pipeline.absorb import absorb_gaps, absorbed, slides
from floorplan.solver.pipeline.assemble import explained, final_layout, no_layout, same_layout
from floorplan.solver.pipeline.first_layout import first_level
from floorplan.solver.pipeline.hierarchy import GAP_AREA, Piece, as_pieces, room_boxes
from floorplan.solver.pipeline.refine import refine, reshaped
from floorplan.solver.pipeline.repair import repaired
from floorplan.solver.pipeline.run import Run, covered, covers, exact
from floorplan.solver.pipeline.second_search import (
    GUILLOTINE,
    awaited,
    better_final,
    better_start,
    guillotine_here,
    second_start,
    tilings_first,
)
from floorplan.solver.pipeline.subdomains import LevelOneOutcome, SubdomainExecutor
from floorplan.solver.stopping import GoodEnough, good_rank
from floorplan.solver.verify.checker import check_layout
from floorplan.solver.verify.precheck import find_impossibilities

#: Rooms moved across gaps at most, when the levels end short of the coverage goal
#: (`_slid`).
SLIDES = 3


def solve_floor(
    problem: Problem,
    *,
    on_event: EventSink | None = None,
    should_stop: StopFlag | None = None,
    subdomains: SubdomainExecutor | None = None,
) -> Layout:
    """Lay out a single-floor `problem` without regions: a valid layout, or a report
    saying why there is none. With `subdomains`, the sub-domains of each refinement level
    are solved at the same time on its executor; without, one after the other."""
    if problem.options.redraws and problem.options.diverse and problem.options.stop_when_good:
        return _drawn_until_good(problem, on_event=on_event, should_stop=should_stop,
                                 subdomains=subdomains)
    started = time.monotonic()
    asked = problem
    if problem.options.diverse:
        # A batch's layout: the seed's own sizes to aim at, within the brief's bounds,
        # and perhaps a room starting as an L (docs/method.md, "Different plans per seed
        # (batches)").
        problem = diverse_problem(problem, problem.options.seed)
    # The doors every room needs, as adjacencies the MIQP must honour.
    problem = connection_demands(problem)
    good: GoodEnough | None = None
    if problem.options.stop_when_good:
        good = GoodEnough(problem, math.inf)
        on_event, should_stop = _stop_when_good(good, on_event, should_stop)
    limit = problem.options.time_limit or default_time_limit(len(problem.rooms))
    late = problem.options.time_limit is None  # the default limit: a late allowance
    budget = FloorBudget.of(started, limit, len(problem.rooms), late=late)
    run = Run(problem, budget.search_end, started, on_event, should_stop, asked=asked,
              end=budget.end, judge_end=budget.judge_end,
              late_by=budget.late_by if late else 0.0)
    domain = make_domain(problem)
    findings = find_impossibilities(problem, domain)  # soft constraints never refuse
    if findings:
        return no_layout(run, Termination.INFEASIBLE, explained(run, domain, Infeasibility(
            reason="the problem is infeasible before any solving", findings=findings)))
    run.emit(Phase.LEVEL, detail="level 1: one rectangle per room")
    level_one_end = budget.level_one_end
    second = second_start(problem, domain, subdomains, level_one_end)
    # The guillotine search's layout (solver/heuristics/guillotine/), which competes
    # with the finished one.
    candidate: LevelOneOutcome | None = None
    if second is None:
        candidate = tilings_first(run, domain)
        if _exact(run, domain, candidate):
            # An exact tiling: Eq. 12 is zero, its least value, so nothing after it can
            # gain; SCIP's check of the answer still takes it as a start.
            assert candidate is not None
            return final_layout(run, domain, better_final(run, domain, [], candidate), 1)
    pieces, failure = first_level(run, domain, level_one_end)
    if second is not None:
        proven = failure is not None and failure.report.termination is Termination.INFEASIBLE
        if proven or run.stopped() or _settled(run, domain, pieces):
            # Nothing the second search finds can be used, or level 1 ends the solve (as
            # without a pool): it is not waited for.
            second.cancel()
        elif (other := awaited(second, run, level_one_end)) is not None and (
                other.found_by == GUILLOTINE):
            candidate = other
        else:
            pieces = better_start(run, domain, pieces, other)
    elif (candidate is None or candidate.pieces is None) and (
            failure is None or failure.report.termination is not Termination.INFEASIBLE
    ) and not (good is not None and problem.options.diverse) and not _settled(
            run, domain, pieces):
        # (Not for a batch's layout, which stops when good: when level 1 gave none,
        # another draw of level 1 (`_redrawn`) gives one sooner than this search.)
        candidate = guillotine_here(run, domain)
    if good is not None and problem.options.diverse:
        run, pieces, failure = _redrawn(run, domain, pieces, failure, good, level_one_end)
        problem = run.problem
    if pieces is None and candidate is not None and candidate.pieces is not None:
        pieces, candidate = better_final(run, domain, [], candidate), None
    if pieces is None:
        assert failure is not None
        return failure
    if time.monotonic() > budget.level_one_end:
        # Level 1 ended late: the later stages keep their shares from now; under the
        # default limit a first layout found after level 1's share marks a hard brief,
        # whose stages get the longer shares.
        now = time.monotonic()
        hard = late and run.first_at is not None and run.first_at > budget.level_one_end
        budget = budget.hard(now, len(problem.rooms)) if hard else budget.shifted(now)
        run.deadline, run.end, run.judge_end = budget.search_end, budget.end, budget.judge_end
    if good is not None and good.rooms is not None:
        # Stopped when good: that layout, not whatever SCIP reported after it.
        pieces = as_pieces(good.rooms)
        return final_layout(run, domain, pieces, 1)
    if _settled(run, domain, pieces):
        # SCIP proved the whole floor's MIQP optimal and its layout covers the floor: the
        # gap is closed, so the solve ends here, as the paper's does.
        return final_layout(run, domain, better_final(run, domain, pieces, candidate), 1)
    pieces, levels = _refined(run, domain, pieces, subdomains, budget.short_end)
    pieces = run.better_of(domain, pieces)
    run.deadline = budget.end
    pieces = reshaped(run, domain, pieces, budget.end)
    if late and not run.stopped() and not covers(domain, room_boxes(pieces)):
        pieces, levels = _covered_late(run, domain, pieces, subdomains, budget, levels)
    pieces = better_final(run, domain, pieces, candidate)
    if good is not None and good.rooms is not None:
        pieces = as_pieces(good.rooms)  # good during the refinement or the reshaping
    return final_layout(run, domain, pieces, levels)


def _drawn_until_good(
    problem: Problem, *, on_event: EventSink | None, should_stop: StopFlag | None,
    subdomains: SubdomainExecutor | None,
) -> Layout:
    """`options.redraws` (a batch's layout as a job of the service): the solve
    laid out again whole under another draw of the seed (`models.options.REDRAW_SEED_STEP`)
    while it ends without a good layout, each draw an equal share of the time left, as
    `floorplan batch` does between solves. The first good layout, else the best of the
    draws (valid first, then the most floor covered); its solve_time counts every draw."""
    started = time.monotonic()
    limit = problem.options.time_limit or default_time_limit(len(problem.rooms))
    draws = problem.options.redraws + 1
    best: Layout | None = None
    for k in range(draws):
        share = (limit - (time.monotonic() - started)) / (draws - k)
        if best is not None and (share < 0.5 * limit / draws
                                 or (should_stop is not None and should_stop())):
            break
        seed = (problem.options.seed + k * WHOLE_REDRAW_SEED_STEP) % 2**31
        layout = solve_floor(problem.with_options(seed=seed, redraws=0, time_limit=share),
                             on_event=on_event, should_stop=should_stop, subdomains=subdomains)
        if best is None or good_rank(layout) > good_rank(best):
            best = layout
        if good_rank(layout)[0]:
            break
    assert best is not None
    return best.model_copy(update={"report": best.report.model_copy(
        update={"solve_time": time.monotonic() - started})})


def _refined(run: Run, domain: Domain, pieces: list[Piece],
             subdomains: SubdomainExecutor | None, later: float, *, after: int = 1
             ) -> tuple[list[Piece], int]:
    """The hierarchy's levels, their last gaps absorbed; when they end short of the
    coverage goal (level 1 took most of the time), a second round until `later`, taken
    from the reshaping: coverage decides whether the layout is valid, the reshaping only
    polishes its sizes."""
    pieces, levels = refine(run, domain, pieces, subdomains, after=after)
    filled = _slid(run, domain, absorb_gaps(run.problem, domain, pieces))
    if run.stopped() or covers(domain, room_boxes(filled)):
        return filled, levels
    run.deadline = max(run.deadline, later)
    # Growing rooms did not close the gaps: the rooms around them laid out afresh.
    filled = repaired(run, domain, filled)
    if run.stopped() or covers(domain, room_boxes(filled)):
        return filled, levels
    run.emit(Phase.LEVEL, detail="the levels ended short of the coverage goal: another round")
    pieces, levels = refine(run, domain, pieces, subdomains, after=levels)
    again = _slid(run, domain, absorb_gaps(run.problem, domain, pieces))
    if covered(domain, room_boxes(filled)) > covered(domain, room_boxes(again)):
        return filled, levels  # the rooms laid out afresh came nearer the goal
    return again, levels


def _covered_late(run: Run, domain: Domain, pieces: list[Piece],
                  subdomains: SubdomainExecutor | None, budget: FloorBudget, levels: int
                  ) -> tuple[list[Piece], int]:
    """Under the default limit, a layout still short of the coverage goal after the
    reshaping: the refinement and the reshaping again, each with the share it had, while
    the late allowance (`solver.budget.late_allowance`) leaves a round's time and each
    round covers more. A busy machine then slows the answer rather than leaving floor
    bare; a covering layout never waits for this."""
    while not run.stopped() and not covers(domain, room_boxes(pieces)):
        budget = budget.shifted(time.monotonic())  # from now, each later stage its share
        if budget.search_end - time.monotonic() < 0.05:
            break  # the allowance leaves the levels no time
        run.emit(Phase.LEVEL, detail="short of the coverage goal at the limit: the levels "
                 "and the reshaping again (the default limit's late allowance)")
        run.deadline, run.end, run.judge_end = budget.search_end, budget.end, budget.judge_end
        again, levels = _refined(run, domain, pieces, subdomains, budget.short_end,
                                 after=levels)
        again = run.better_of(domain, again)
        run.deadline = budget.end
        again = reshaped(run, domain, again, budget.end)
        if covered(domain, room_boxes(again)) <= covered(domain, room_boxes(pieces)) + GAP_AREA:
            break  # a round that covers no more: another would not either
        pieces = again
    return pieces, levels


def _slid(run: Run, domain: Domain, pieces: list[Piece]) -> list[Piece]:
    """`pieces` short of the coverage goal with rooms moved across the gaps no
    neighbour may grow into (`slides`), one move at a time while one covers more and
    passes the checker, at most `SLIDES` moves."""
    for _ in range(SLIDES):
        if run.stopped() or covers(domain, room_boxes(pieces)):
            break
        now = covered(domain, room_boxes(pieces))
        better = next((moved for moved in slides(run.problem, domain, pieces)
                       if covered(domain, room_boxes(moved)) > now + GAP_AREA
                       and check_layout(run.problem, room_boxes(moved)).valid), None)
        if better is None:
            break
        run.incumbent(domain, room_boxes(better))
        pieces = better
    return pieces


def _settled(run: Run, domain: Domain, pieces: list[Piece] | None) -> bool:
    """Whether `pieces` are SCIP's answer to the whole floor's MIQP, covering the floor,
    under `options.stop` "stalled", and SCIP either proved them optimal or its search
    stalled on them (a floor small enough to be solved outright): no stage after level 1
    can lower Eq. 12 within the model, or the heuristic stages after it are no longer
    spent on it, so none runs."""
    answer = run.scip_answer
    if pieces is None or answer is None or run.problem.options.stop != "stalled" or not (
            answer.optimal or run.stage_stalled):
        return False
    rooms = room_boxes(pieces)
    return same_layout(answer.rooms, rooms) and covers(domain, rooms)


def _exact(run: Run, domain: Domain, candidate: LevelOneOutcome | None) -> bool:
    """Whether `candidate` (gaps absorbed, as the answer would be) covers the floor,
    passes the checker and has Eq. 12 of zero, the objective's least value."""
    if candidate is None or candidate.pieces is None or run.problem.options.diverse:
        return False
    return exact(run.problem, domain, room_boxes(absorb_gaps(run.problem, domain,
                                                             candidate.pieces)))


def _stop_when_good(good: GoodEnough, on_event: EventSink | None,
                    should_stop: StopFlag | None) -> tuple[EventSink, StopFlag]:
    """`options.stop_when_good`: the event sink and stop flag of a solve that also ends
    when `good` is reached (its first incumbent passing the checker and covering
    `solver.stopping.DEFAULT_COVERAGE`)."""

    def sink(event: SolveEvent) -> None:
        good(event)
        if on_event is not None:
            on_event(event)

    def stop() -> bool:
        return good.reached or (should_stop is not None and should_stop())

    return sink, stop


def _redrawn(
    run: Run, domain: Domain, pieces: list[Piece] | None, failure: Layout | None,
    good: GoodEnough, level_one_end: float,
) -> tuple[Run, list[Piece] | None, Layout | None]:
    """A diverse solve that stops when good (a batch's layout) whose level 1
    ended early without a good layout: level 1 again, under sizes and an arrangement
    drawn from another seed (`REDRAW_SEED_STEP`), `REDRAWS` times at most while
    `REDRAW_MIN_SHARE` of level 1's time is left, each draw but the last with an equal
    share of what is left. Level 1 usually ends so because the optimum of the seed's
    sizes leaves floor bare; the refinement levels and the reshaping rarely cover it,
    and another draw usually is good at once. (Cutting the first draw short to make room
    for others cost a 13-room house half its good layouts in bench batch: 8 of 20
    against 16-18; bench/NOTES.md, "Batches: distinct plans by construction, and their
    cost".) Returns the run, pieces and failure to go on with: the last attempt's when it
    is good, else the attempt whose pieces cover the most floor."""
    asked = run.asked or run.problem
    share = level_one_end - run.started
    covered_by = _covered_floor(run, domain, pieces)
    for attempt in range(1, REDRAWS + 1):
        left = level_one_end - time.monotonic()
        if good.reached or run.stopped() or left < REDRAW_MIN_SHARE * share:
            break
        # Each draw but the last gets an equal share of what is left.
        until = time.monotonic() + left / (REDRAWS - attempt + 1)
        seed = (asked.options.seed + attempt * REDRAW_SEED_STEP) % 2**31
        drawn = connection_demands(diverse_problem(asked.with_options(seed=seed), seed))
        again = Run(drawn, run.deadline, run.started, run.on_event, run.should_stop,
                    asked=asked, end=run.end)
        again.emit(Phase.RELAXATION, detail=f"level 1 gave no good layout: sizes and "
                   f"arrangement drawn again (seed {seed})")
        candidate, why = first_level(again, domain, until)
        covers = _covered_floor(again, domain, candidate)
        if candidate is not None and (good.reached or covers > covered_by):
            run, pieces, failure, covered_by = again, candidate, why, covers
    return run, pieces, failure


def _covered_floor(run: Run, domain: Domain, pieces: list[Piece] | None) -> float:
    """The floor `pieces` cover once gaps are absorbed (-1 without pieces)."""
    if pieces is None:
        return -1.0
    return covered(domain, absorbed(run.problem, domain, room_boxes(pieces)))
