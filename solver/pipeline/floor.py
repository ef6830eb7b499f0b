"""One floor's solve: demands, prechecks, level 1, the hierarchy, the last gaps, the
reshaping and the independent check.

Time policy (paper Sec. 5.4): 5 s up to 20 rooms, growing in proportion beyond
(`solver.budget`). The reshaping keeps `RESHAPE_SHARE` of it (capped) for the end; of
the search time before, level 1 gets `LEVEL_ONE_SHARE` and the refinement levels share
the rest. A search that finds no first layout may go on to the end.
"""

from __future__ import annotations

import math
import time

from models import Infeasibility, Layout, Problem, Termination
from solver.budget import default_time_limit
from solver.events import EventSink, Phase, SolveEvent, StopFlag
from solver.geometry import make_domain
from solver.heuristics.variety import diverse_problem
from solver.openings import connection_demands
from solver.pipeline.assemble import explained, final_layout, no_layout
from solver.pipeline.first_layout import better_start, first_level, second_start
from solver.pipeline.hierarchy import absorb_gaps
from solver.pipeline.refine import refine, reshaped
from solver.pipeline.run import Run
from solver.pipeline.subdomains import SubdomainExecutor
from solver.stopping import GoodEnough
from solver.verify.precheck import find_impossibilities

#: Share of the time limit level 1 may use.
LEVEL_ONE_SHARE = 0.9
#: Share of the search time kept for reshaping the rooms at the end (issue 19), up to
#: `RESHAPE_SECONDS` and `RESHAPE_SECONDS_PER_ROOM` more per room.
RESHAPE_SHARE = 0.15
RESHAPE_SECONDS = 1.0
RESHAPE_SECONDS_PER_ROOM = 0.1
#: Time kept per room for closing the last gaps and checking the layout.
FINISH_SECONDS_PER_ROOM = 0.01


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
    started = time.monotonic()
    asked = problem
    if problem.options.diverse:
        # Issue 23: the seed's own sizes to aim at, within the brief's bounds, and
        # perhaps a room starting as an L.
        problem = diverse_problem(problem, problem.options.seed)
    # The doors every room needs, as adjacencies the MIQP must honour.
    problem = connection_demands(problem)
    if problem.options.stop_when_good:
        on_event, should_stop = _stop_when_good(problem, on_event, should_stop)
    limit = problem.options.time_limit or default_time_limit(len(problem.rooms))
    # The last gaps and the check run after the search: keep time for them.
    reserve = min(limit * 0.1, FINISH_SECONDS_PER_ROOM * len(problem.rooms))
    # Level 1 and the hierarchy search until `search_end`; the reshaping has the rest.
    end = started + limit - reserve
    reshaping = min(RESHAPE_SHARE * (end - started),
                    RESHAPE_SECONDS + RESHAPE_SECONDS_PER_ROOM * len(problem.rooms))
    search_end = end - reshaping
    run = Run(problem, search_end, started, on_event, should_stop, asked=asked, end=end)
    domain = make_domain(problem)
    findings = find_impossibilities(problem, domain)  # soft constraints never refuse
    if findings:
        return no_layout(run, Termination.INFEASIBLE, explained(run, domain, Infeasibility(
            reason="the problem is infeasible before any solving", findings=findings)))
    run.emit(Phase.LEVEL, detail="level 1: one rectangle per room")
    level_one_end = started + (run.deadline - started) * LEVEL_ONE_SHARE
    second = second_start(problem, subdomains, level_one_end)
    pieces, failure = first_level(run, domain, level_one_end)
    if second is not None:
        proven = failure is not None and failure.report.termination is Termination.INFEASIBLE
        if proven or run.stopped():  # nothing the second search finds can be used
            second.cancel()
        else:
            pieces = better_start(run, domain, pieces, second, level_one_end)
    if pieces is None:
        assert failure is not None
        return failure
    pieces, levels = refine(run, domain, pieces, subdomains)
    pieces = run.better_of(domain, absorb_gaps(problem, domain, pieces))
    run.deadline = end
    pieces = reshaped(run, domain, pieces, min(end, time.monotonic() + reshaping))
    return final_layout(run, domain, pieces, levels)


def _stop_when_good(problem: Problem, on_event: EventSink | None,
                    should_stop: StopFlag | None) -> tuple[EventSink, StopFlag]:
    """`options.stop_when_good`: the event sink and stop flag of a solve that also ends
    at its first incumbent passing the checker and covering `DEFAULT_COVERAGE`."""
    good = GoodEnough(problem, math.inf)

    def sink(event: SolveEvent) -> None:
        good(event)
        if on_event is not None:
            on_event(event)

    def stop() -> bool:
        return good.reached or (should_stop is not None and should_stop())

    return sink, stop
