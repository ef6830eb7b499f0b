"""`solve(problem) -> Layout`: the one entry point. A building of several storeys goes a
floor at a time (`solver.pipeline.storeys`); a floor with regions, or more rooms than
`options.regions_above`, through regions and aisles (`solver.pipeline.regions`); any
other floor through the single-floor pipeline (`solver.pipeline.floor`). Design variants
(`solver.pipeline.variants`) wrap all of these; fixed rooms (`solver.pipeline.fixed`)
wrap a single floor's solve. The storeys
and regions steps are handed this very function for their floors and parts."""

from __future__ import annotations

from floorplan.models import Layout, Problem
from floorplan.solver.events import EventSink, StopFlag
from floorplan.solver.pipeline.fixed import has_fixed, solve_fixed
from floorplan.solver.pipeline.floor import solve_floor
from floorplan.solver.pipeline.regions import regions_apply, solve_regions
from floorplan.solver.pipeline.storeys import solve_storeys
from floorplan.solver.pipeline.subdomains import SubdomainExecutor
from floorplan.solver.pipeline.variants import solve_variants


def solve(
    problem: Problem,
    *,
    on_event: EventSink | None = None,
    should_stop: StopFlag | None = None,
    subdomains: SubdomainExecutor | None = None,
) -> Layout:
    """Lay out `problem`: a valid layout, or a report saying why there is none. With
    `subdomains`, the sub-domains of each refinement level are solved at the same time
    on its executor; without, one after the other."""
    if problem.options.variants > 1:
        return solve_variants(problem, solve=solve, on_event=on_event,
                              should_stop=should_stop, subdomains=subdomains)
    if problem.floors is None and has_fixed(problem):
        return solve_fixed(problem, solve=solve, on_event=on_event, should_stop=should_stop,
                           subdomains=subdomains)
    if problem.floors is not None:
        return solve_storeys(problem, solve=solve, on_event=on_event,
                             should_stop=should_stop, subdomains=subdomains)
    if regions_apply(problem):
        return solve_regions(problem, solve=solve, on_event=on_event, should_stop=should_stop)
    return solve_floor(problem, on_event=on_event, should_stop=should_stop,
                       subdomains=subdomains)
