"""The second search alongside level 1 (docs/method.md, 'Two searches at once'): the
guillotine search where it applies (`guillotine_alone`), whose layout competes with the
finished one (`better_final`), else a level-1 search under another seed
(`level_one_alone`), whose start competes with level 1's (`better_start`); and the
guillotine search in the solve's own process when no pool runs it alongside
(`tilings_first` before level 1, `guillotine_here` after)."""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import Future, wait

from floorplan.models import ExtraRectangles, Problem
from floorplan.solver.events import Phase
from floorplan.solver.geometry import Domain, make_domain
from floorplan.solver.heuristics.guillotine import MAX_ROOMS as GUILLOTINE_MAX_ROOMS
from floorplan.solver.heuristics.guillotine import applies as guillotine_applies
from floorplan.solver.heuristics.guillotine import guillotine_layout
from floorplan.solver.heuristics.level_one import may_start_as_l, started_as_l, wing_order
from floorplan.solver.pipeline.absorb import absorb_gaps, absorbed
from floorplan.solver.pipeline.first_layout import first_level
from floorplan.solver.pipeline.hierarchy import Piece, as_pieces, room_boxes
from floorplan.solver.pipeline.run import Run, covers, exact, layout_objective
from floorplan.solver.pipeline.subdomains import (
    LATE_SECONDS,
    LevelOneOutcome,
    LevelOneTask,
    SubdomainExecutor,
)
from floorplan.solver.verify.checker import check_layout

#: The second level-1 search of a portfolio runs under the seed plus this.
SECOND_SEED_STEP = 1_000_003
#: Why a room of a second level-1 search's layout is an L when the brief did not ask.
L_START_REASON = "the second level-1 search started the largest room as an L"
#: How the report names the guillotine search's layout.
GUILLOTINE = ("a guillotine search (rooms as the parts of a slicing tree, L and T rooms "
              "among them)")
#: Share of the search time left after level 1 the guillotine search takes when it
#: cannot run alongside.
INLINE_GUILLOTINE_SHARE = 0.4
#: Share of the solve the exact tilings may take before level 1 when the guillotine
#: search cannot run alongside.
EARLY_TILING_SHARE = 0.3


def second_start(
    problem: Problem, domain: Domain, subdomains: SubdomainExecutor | None, deadline: float
) -> Future[LevelOneOutcome] | None:
    """With an executor of two slots or more, a second search alongside level 1: the
    guillotine search (`guillotine_alone`) where it applies, whose layout competes with
    the finished one (`better_final`), else a level-1 search under another seed
    (`level_one_alone`, `better_start`). Level 1 is a local search whose first layout
    fixes which room lies next to which; a second one that starts elsewhere ends better
    often enough to pay (bench/NOTES.md). None when there is no such executor, or it
    runs only sub-domains (a remote one)."""
    if subdomains is None or subdomains.slots < 2:
        return None
    task = _second_task(problem, deadline - time.monotonic())
    search = guillotine_alone if guillotine_applies(problem, domain) else level_one_alone
    try:
        return subdomains.executor.submit(search, task)
    except (ValueError, RuntimeError):  # an executor for sub-domains only, or shut down
        return None


def tilings_first(run: Run, domain: Domain) -> LevelOneOutcome | None:
    """The guillotine search from exact tilings only, in this process before level 1,
    when it applies and cannot run alongside: a tiling, when there is one, is mostly
    found within a fraction of a second, and its layout is the plan's quality; the
    search gets at most `EARLY_TILING_SHARE` of the solve."""
    if not guillotine_applies(run.problem, domain) or run.stopped():
        return None
    seconds = EARLY_TILING_SHARE * max(0.0, run.deadline - time.monotonic())
    return guillotine_alone(_second_task(run.problem, seconds), should_stop=run.should_stop,
                            untiled=False, then_level_one=False)


def guillotine_here(run: Run, domain: Domain) -> LevelOneOutcome | None:
    """The guillotine search from random trees in this process, after level 1, when it
    applies, did not run alongside and found no tiling first: in
    `INLINE_GUILLOTINE_SHARE` of the search time left, taken from the refinement."""
    if not guillotine_applies(run.problem, domain) or run.stopped():
        return None
    seconds = INLINE_GUILLOTINE_SHARE * max(0.0, run.deadline - time.monotonic())
    return guillotine_alone(_second_task(run.problem, seconds), should_stop=run.should_stop,
                            tiled=False, then_level_one=False)


def _second_task(problem: Problem, seconds: float) -> LevelOneTask:
    """A second search's task: `problem` under another seed, ending in `seconds` (the
    deadline as epoch time, for another process)."""
    seed = (problem.options.seed + SECOND_SEED_STEP) % 2**31
    return LevelOneTask(problem.with_options(seed=seed), deadline=time.time() + seconds)


def awaited(second: Future[LevelOneOutcome], run: Run, deadline: float) -> LevelOneOutcome | None:
    """The second search's outcome, waited for until `deadline` and a little after; None
    when it is late, lost or failed."""
    while not second.done() and not run.stopped() and (
            time.monotonic() < deadline + LATE_SECONDS):
        wait([second], timeout=0.05)
    try:
        return second.result(timeout=0)
    except Exception:  # late, stopped, lost or failed: it costs its chance, not the layout
        second.cancel()
        return None


def better_final(run: Run, domain: Domain, pieces: list[Piece],
                 candidate: LevelOneOutcome | None) -> list[Piece]:
    """The finished layout, or the second search's (gaps absorbed, as the answer will
    be) when the finished one misses the coverage goal or fails the checker, or when
    the second has the lower Eq. 12 and passes the checker. A second level-1 search's
    pieces are level 1's, with its gaps: compared and returned as they will be."""
    if candidate is None or candidate.pieces is None:
        return pieces
    mine = absorbed(run.problem, domain, room_boxes(pieces))
    theirs_pieces = absorb_gaps(run.problem, domain, candidate.pieces)
    theirs = room_boxes(theirs_pieces)
    if pieces and (not check_layout(run.problem, theirs).valid or (
            covers(domain, mine) and check_layout(run.problem, mine).valid and (
                layout_objective(run.problem, domain, mine, soft=run.soft)
                <= layout_objective(run.problem, domain, theirs)))):
        return pieces
    run.wings, run.extra, run.window, run.soft = {}, candidate.extra, None, False
    run.relaxations.append(f"{candidate.found_by} ended better")
    run.emit(Phase.LEVEL, detail=f"{candidate.found_by} ended better")
    run.incumbent(domain, theirs)
    return theirs_pieces


def guillotine_alone(
    task: LevelOneTask, should_stop: Callable[[], bool] | None = None, *,
    tiled: bool = True, untiled: bool = True, then_level_one: bool = True,
) -> LevelOneOutcome:
    """The guillotine search (solver/heuristics/guillotine/) on `task.problem` in
    whatever process the executor uses: a whole layout, its L and T rooms chosen by the
    search, ending by `task.deadline` (epoch). With `then_level_one` (a search alongside
    level 1), a floor too large for it that has no tiling gets a second level-1 search
    instead; in the solve's own process level 1 itself has that time."""
    deadline = time.monotonic() + (task.deadline - time.time())
    problem = task.problem
    domain = make_domain(problem)
    found = guillotine_layout(problem, domain, seed=problem.options.seed,
                              deadline=deadline, should_stop=should_stop,
                              accept=lambda rooms: check_layout(problem, rooms).valid,
                              tiled=tiled, untiled=untiled,
                              enough=lambda rooms: exact(problem, domain, rooms))
    if found is None and len(problem.rooms) > GUILLOTINE_MAX_ROOMS and then_level_one:
        # Beyond that size only an exact tiling seeds it, and there was none: the rest
        # of the time goes to a second level-1 search, the largest room starting as an
        # L when the targets over-ask the floor (as a brief extracted from a plan with
        # L rooms does, a target being a room's bounding box). Such a plan is seldom a
        # tiling of rectangles and one or two Ls, and its largest room is nearly always
        # an L; level 1 in the solve's own process tries rectangles first, so the two
        # searches start from different shapes. (Where the targets leave floor over, an
        # L start ended worse: bench/NOTES.md, 'The second search starts the largest
        # room as an L; medians over three seeds'.)
        return level_one_alone(task, l_start=targets_over_ask(problem, domain))
    if found is None:
        return LevelOneOutcome(None, {}, [], None, False, [])
    extra = [ExtraRectangles(room=room_id, rectangles=len(boxes),
                             reason="the guillotine search made it an L or a T")
             for room_id, boxes in found.rooms.items() if len(boxes) > 1]
    return LevelOneOutcome(as_pieces(found.rooms), {}, extra, None, False, [],
                           found_by=GUILLOTINE)


def level_one_alone(task: LevelOneTask, *, l_start: bool = False) -> LevelOneOutcome:
    """Level 1 of `task.problem` (its demands already added) in whatever process the
    executor uses, without events or stop flag: it ends by `task.deadline` (epoch).
    With `l_start`, the largest room that may be an L starts as one (`l_started`)."""
    started = time.monotonic()
    deadline = started + (task.deadline - time.time())
    problem, l_room = l_started(task.problem) if l_start else (task.problem, None)
    run = Run(problem, deadline, started, None, None)
    domain = make_domain(problem)
    pieces, _ = first_level(run, domain, deadline)
    # The room was not asked to be an L: the report says who made it one.
    extra = [e.model_copy(update={"reason": L_START_REASON}) if e.room == l_room else e
             for e in run.extra]
    return LevelOneOutcome(pieces, run.wings, extra, run.window, run.soft,
                           run.relaxations)


def targets_over_ask(problem: Problem, domain: Domain) -> bool:
    """Whether the rooms' target rectangles add up to more than the floor."""
    asked = sum(r.target_size[0] * r.target_size[1] for r in problem.rooms if r.target_size)
    return asked > domain.area


def l_started(problem: Problem) -> tuple[Problem, str | None]:
    """`problem` with its largest room (by target, `wing_order`) that starts as one
    rectangle and may have more starting as an L (as ``shape: free`` does), and that
    room's id; `problem` and None when no room may."""
    eligible = {r.id for r in problem.rooms if may_start_as_l(r)}
    chosen = next((r for r in wing_order(problem) if r in eligible), None)
    if chosen is None:
        return problem, None
    return started_as_l(problem, chosen), chosen


def better_start(
    run: Run, domain: Domain, pieces: list[Piece] | None, other: LevelOneOutcome | None,
) -> list[Piece] | None:
    """This level 1's pieces, or the second level-1 search's when they are better: a
    layout meeting every constraint before one pricing soft ones, then one meeting the
    coverage goal (gaps absorbed), then the lower Eq. 12."""
    if other is None or other.pieces is None or run.stopped():
        return pieces

    def rank(candidate: list[Piece], soft: bool) -> tuple[bool, bool, float]:
        rooms = absorbed(run.problem, domain, room_boxes(candidate))
        return (soft, not covers(domain, rooms),
                layout_objective(run.problem, domain, rooms, soft=soft))

    if pieces is not None and rank(pieces, run.soft) <= rank(other.pieces, other.soft):
        return pieces
    run.wings, run.extra, run.window, run.soft = (other.wings, other.extra, other.window,
                                                  other.soft)
    run.relaxations.append(f"{other.found_by} ended better")
    run.emit(Phase.LEVEL, detail="level 1: the second search ended better")
    run.incumbent(domain, room_boxes(other.pieces))
    return other.pieces
