"""The hierarchy's refinement levels (Sec. 5.3): sub-domains re-solved level by
level, one after the other or, given an executor, the independent ones at once."""

from __future__ import annotations

import random
import time
from concurrent.futures import FIRST_COMPLETED, Future, wait

from floorplan.solver.budget import significant_gain
from floorplan.solver.events import Phase
from floorplan.solver.geometry import Box, Domain, domain_lines, snap_rooms
from floorplan.solver.heuristics.reshape import reshape
from floorplan.solver.heuristics.wall_slide import slide_walls
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.scip_run import add_start
from floorplan.solver.pipeline.hierarchy import (
    Piece,
    RefinementPlan,
    SubDomain,
    apply_refinement,
    as_pieces,
    plan_refinement,
    room_boxes,
    select_subdomains,
)
from floorplan.solver.pipeline.run import OUTPUT_SNAP, Run, covers, layout_objective
from floorplan.solver.pipeline.subdomains import (
    LATE_SECONDS,
    SubdomainExecutor,
    SubdomainOutcome,
    SubdomainTask,
    overlaps_others,
    solve_subdomain,
)
from floorplan.solver.verify.checker import check_layout

#: The reshaping's steps and the share of its time each ends at: the annealing
#: (solver/heuristics/reshape/), sliding whole walls (wall_slide.py: tens of
#: milliseconds on most floors of a dozen rooms), the annealing again from the slid
#: layout, and a last slide. 94 planted briefs, two runs each: 83-84 within 2x the
#: plan's area error, against 80-81 for one annealing and a slide and 79 for two
#: rounds with equal time (bench/NOTES.md, "Whole walls slid, and the reshaping in two
#: rounds").
RESHAPE_SCHEDULE = (("anneal", 0.55), ("slide", 0.65), ("anneal", 0.9), ("slide", 1.0))
#: Share of the reshaping's time a layout short of the coverage goal gives sliding walls
#: first, to close its gaps (the annealing prices them at lambda_cover only).
SHORT_SLIDE_SHARE = 0.4
#: Python time per room to plan one refinement sub-domain (measured: 0.16 s at 154).
PLAN_SECONDS_PER_ROOM = 0.002


def refine(
    run: Run, domain: Domain, pieces: list[Piece],
    subdomains: SubdomainExecutor | None = None, *, after: int = 1,
) -> tuple[list[Piece], int]:
    """The hierarchy (Sec. 5.3): refine sub-domains level by level while time is left,
    `options.max_levels` - 1 levels numbered from `after` + 1 (a second round goes on
    from the first's last); returns the pieces and the number of the last level used."""
    problem = run.problem
    levels = after
    last = after + problem.options.max_levels - 1
    rng = random.Random(problem.options.seed)
    # Planning a sub-domain costs Python time in proportion to the rooms: do not
    # start one that cannot finish.
    overhead = 0.05 + PLAN_SECONDS_PER_ROOM * len(problem.rooms)
    run.begin_stage()
    before: float | None = None  # Eq. 12 before the last level
    for level in range(after + 1, last + 1):
        if run.remaining() <= overhead or run.ending():
            break
        objective = layout_objective(problem, domain, room_boxes(pieces), soft=run.soft)
        if before is not None and problem.options.stop == "stalled" and not significant_gain(
                before, objective):
            # The last level lowered nothing: the next would select the same sub-domains
            # and re-solve them to the same optimum.
            break
        before = objective
        subs = select_subdomains(problem, domain, pieces)
        if not subs:
            break
        run.level = levels = level
        run.emit(Phase.LEVEL, subdomains=len(subs),
                 detail=f"level {level}: {len(subs)} sub-domain(s)")
        levels_left = last - level + 1
        if subdomains is not None and len(subs) > 1:
            level_seconds = run.remaining() / levels_left
            for batch in _disjoint_batches(subs):
                if run.remaining() <= overhead or run.ending():
                    break
                # Planned from the layout as the previous batch left it.
                plans = [(i, plan_refinement(problem, domain, pieces, sub, level=level,
                                             index=i, rng=rng)) for i, sub in batch]
                seconds = min(level_seconds * len(batch) / len(subs), run.remaining())
                pieces = _refine_at_once(run, domain, pieces, plans, len(subs), seconds,
                                         subdomains)
            continue
        for i, sub in enumerate(subs):
            if run.remaining() <= overhead or run.ending():
                break
            budget = run.remaining() / levels_left / (len(subs) - i)
            plan = plan_refinement(problem, domain, pieces, sub, level=level, index=i, rng=rng)
            lm = build_level(plan.spec)
            start = add_start(lm, plan.start)
            if start.values is None:
                run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=len(subs),
                         detail=f"start not feasible: {start.status}")
                continue
            result = run.run(lm, budget - start.seconds)
            if result.rects is not None:
                pieces = apply_refinement(pieces, plan, result.rects)
                run.incumbent(domain, room_boxes(pieces), sub=i + 1, subs=len(subs))
            run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=len(subs),
                     objective=result.objective,
                     detail=f"rooms {', '.join(sorted(sub.rooms))}: {result.status}")
    return pieces, levels


def _disjoint_batches(subs: list[SubDomain]) -> list[list[tuple[int, SubDomain]]]:
    """Consecutive runs of sub-domains sharing no room: those are independent problems.
    (Selections too large to merge may share rooms; each such one starts a new batch.)"""
    batches: list[list[tuple[int, SubDomain]]] = []
    taken: set[str] = set()
    for i, sub in enumerate(subs):
        if not batches or taken & sub.rooms:
            batches.append([])
            taken = set()
        batches[-1].append((i, sub))
        taken |= sub.rooms
    return batches


def _refine_at_once(
    run: Run, domain: Domain, pieces: list[Piece], plans: list[tuple[int, RefinementPlan]],
    total: int, seconds: float, subdomains: SubdomainExecutor,
) -> list[Piece]:
    """Independent sub-domains (`plans`, by their index among the level's `total`)
    solved at the same time within `seconds`, in waves of the executor's slots; results
    applied in order, unless one overlaps rooms placed by an earlier one. A stop
    returns with what has finished."""
    budget = subdomains.budget(seconds, len(plans))
    deadline = time.time() + seconds
    seed = run.problem.options.seed
    futures: dict[Future[SubdomainOutcome], int] = {
        subdomains.executor.submit(
            solve_subdomain, SubdomainTask(plan.spec, plan.start, budget, deadline, seed)): i
        for i, plan in plans}
    outcomes: dict[int, SubdomainOutcome] = {}
    pending = set(futures)
    while pending and not run.ending() and time.time() < deadline + LATE_SECONDS:
        done, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
        for future in done:
            try:
                outcomes[futures[future]] = future.result()
            except Exception as err:  # a lost task costs its sub-domain, not the layout
                outcomes[futures[future]] = SubdomainOutcome(f"failed: {err}", None, None, 0)
    for future in pending:
        future.cancel()
    n = total
    for i, plan in plans:
        outcome = outcomes.get(i)
        if outcome is None:
            run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=n, detail="stopped")
            continue
        rooms = {h.room for h in plan.pieces.values()}
        if outcome.rects is not None and overlaps_others(
                room_boxes(pieces), rooms, outcome.rects.values()):
            outcome = SubdomainOutcome("dropped: overlaps a neighbouring sub-domain",
                                       None, outcome.objective, outcome.seconds)
        if outcome.rects is not None:
            pieces = apply_refinement(pieces, plan, outcome.rects)
            run.incumbent(domain, room_boxes(pieces), sub=i + 1, subs=n)
        run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=n, objective=outcome.objective,
                 detail=f"rooms {', '.join(sorted(rooms))}: {outcome.status} "
                        f"in {outcome.seconds:.2f} s")
    return pieces


def reshaped(run: Run, domain: Domain, pieces: list[Piece], deadline: float) -> list[Piece]:
    """The size-error trigger of Sec. 5.3 carried to its end (docs/method.md, "The
    steps", step 6): strips of floor move between neighbouring rooms, so a room the
    first layout had to stretch gives back floor and a neighbour becomes an L or a T,
    and whole walls slide (`reshaping_stages`). Kept only when the result is valid,
    covers, and lowers Eq. 12, or covers where the layout did not."""
    run.begin_stage()
    if deadline <= time.monotonic() or run.ending():
        return pieces
    # Walls SCIP placed 1e-7 apart made one, as the output will have them.
    rooms = snap_rooms(room_boxes(pieces), *domain_lines(run.problem), OUTPUT_SNAP)
    before = layout_objective(run.problem, domain, rooms, soft=run.soft)
    run.emit(Phase.LEVEL, detail="reshaping: strips of floor between neighbours")
    short = not covers(domain, rooms)
    # The last layout first, else the one before: each stage lowers the reshaping's
    # cost, not always Eq. 12, which the last word has.
    for new in reversed(reshaping_stages(run, domain, rooms, deadline, short=short)):
        if covers(domain, new) and (short or layout_objective(
                run.problem, domain, new, soft=run.soft) <= before) and check_layout(
                run.problem, new).valid:
            run.incumbent(domain, new)
            return as_pieces(new)
    return pieces


def reshaping_stages(run: Run, domain: Domain, rooms: dict[str, list[Box]],
                     deadline: float, *, short: bool) -> list[dict[str, list[Box]]]:
    """The layouts the reshaping goes through until `deadline`, each changed from the
    one before and lower in the reshaping's cost: for a layout `short` of the coverage
    goal, walls slid first to close its gaps (up to `SHORT_SLIDE_SHARE` of the time);
    then the annealing and a slide, twice (`RESHAPE_SCHEDULE`), the second annealing
    from the slid layout under another seed: the annealing cannot chain what a slide
    does, and after a slide it starts somewhere new."""
    problem, stop = run.problem, run.ending
    stages: list[dict[str, list[Box]]] = []
    if short:
        now = time.monotonic()
        closed, moves = slide_walls(problem, domain, rooms, should_stop=stop,
                                    deadline=now + SHORT_SLIDE_SHARE * (deadline - now))
        if moves:
            stages.append(rooms := closed)
    now = time.monotonic()
    for k, (step, until) in enumerate(RESHAPE_SCHEDULE):
        if time.monotonic() >= deadline or run.stopped() or (step == "anneal"
                                                             and run.ending()):
            # A stalled reshaping anneals no more; a slide costs milliseconds and may
            # still gain, so it runs.
            continue
        end = now + until * (deadline - now)
        if step == "anneal":
            annealed = reshape(problem, domain, rooms, deadline=end,
                               seed=problem.options.seed + k, should_stop=stop,
                               on_progress=run.note_progress)
            changed, new = annealed.steps > 0, annealed.rooms
        else:
            new, moves = slide_walls(problem, domain, rooms, deadline=end, should_stop=stop)
            changed = moves > 0
        if changed:
            stages.append(rooms := new)
    return stages
