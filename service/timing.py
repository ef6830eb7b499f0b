"""A job's time limit as the service runs it (POST /v1/layouts, a batch's layouts):
the problem's own, capped at FLOORPLAN_MAX_TIME_LIMIT."""

from __future__ import annotations

from floorplan.models import Problem
from floorplan.solver.pipeline.storeys import job_ceiling, job_time_limit
from floorplan.solver.pipeline.variants import variant_time_factor


def effective_time_limit(problem: Problem, ceiling: float) -> tuple[Problem, float]:
    """The problem as it will be solved, and the whole job's time limit, at most
    `ceiling` (FLOORPLAN_MAX_TIME_LIMIT). A limit the user gave above it was refused
    already (422); the default, which grows with the rooms and adds up over a
    building's floors, is capped at it, and the capped limit written into the problem
    so that the solve divides that time among its floors. With design variants
    (options.variants above 1) the job may take `variant_time_factor` times one
    layout's limit, and one layout's limit is cut so that the whole stays under
    `ceiling`."""
    factor = variant_time_factor(problem)
    time_limit = job_time_limit(problem)
    if factor == 1 and time_limit <= ceiling:
        # One layout under the default limit may take its late allowance.
        return problem, min(job_ceiling(problem), ceiling)
    if time_limit * factor <= ceiling:
        return problem, time_limit * factor
    return problem.with_options(time_limit=ceiling / factor), ceiling
