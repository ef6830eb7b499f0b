"""POST /v1/validate: a problem checked without solving it."""

from __future__ import annotations

from functools import partial
from typing import Annotated

from fastapi import APIRouter, Query, Request

from floorplan.service.api.body import PROBLEM_BODY_DOC, problem_body, run_off_loop
from floorplan.service.api.deps import LimitsDep, OwnerDep, SettingsDep
from floorplan.service.api.errors import ApiError
from floorplan.service.api.schemas import Validation
from floorplan.solver.geometry import make_domain
from floorplan.solver.verify.conflicts import diagnose
from floorplan.solver.verify.precheck import find_impossibilities

#: Seconds POST /v1/validate?explain=true spends by default, and at most (never more
#: than FLOORPLAN_MAX_TIME_LIMIT either).
EXPLAIN_SECONDS = 3.0
EXPLAIN_MAX_SECONDS = 30.0

router = APIRouter(tags=["service"])


@router.post("/v1/validate", response_model=Validation, openapi_extra=PROBLEM_BODY_DOC,
             response_model_exclude_unset=True,
             responses={401: {"description": "API keys are set and none valid was given"},
                        413: {"description": "the body, or an outline, the obstacles or the "
                              "regions, larger than the service takes"},
                        415: {"description": "the body not sent as application/json"},
                        429: {"description": "this key's explaining validations at their "
                              "limit"},
                        503: {"description": "the process explaining it was lost (it is "
                              "replaced): try again"}})
async def validate_problem(
    request: Request, settings: SettingsDep, owner: OwnerDep, limits: LimitsDep,
    explain: Annotated[bool, Query(
        description="also ask SCIP, briefly, whether a layout exists, and when none "
        "does, which constraints cannot hold together")] = False,
    time_limit: Annotated[float, Query(
        gt=0, le=EXPLAIN_MAX_SECONDS, description="seconds explain may take (at most "
        "the service's largest options.time_limit)")] = EXPLAIN_SECONDS,
) -> Validation:
    """Check a problem without solving it: the schema, then the cheap impossibilities
    (total area, sizes that fit nowhere, contradictory ratios, ...). With `explain`,
    a short SCIP check of the whole problem follows, and a conflict search when no
    layout can exist. A well-formed problem comes back as it would be solved, a
    template expanded."""
    try:
        problem, _raw = await problem_body(request, settings, owner)
    except ApiError as err:
        if err.status != 422:
            raise
        return Validation(valid=False, errors=err.errors or [], findings=[])
    if not explain:
        # Off the event loop (the domain too): the cheap checks still grow with the problem.
        findings = await run_off_loop(
            request, lambda: find_impossibilities(problem, make_domain(problem)))
        # exclude_unset on the answer: the problem shows what was given or filled in.
        return Validation(valid=not findings, errors=[], findings=findings, problem=problem)
    seconds = min(time_limit, settings.max_time_limit)
    release = limits.explain(owner)
    try:
        found = await limits.run_explain(partial(diagnose, problem, time_limit=seconds))
    finally:
        release()
    return Validation(valid=not found.findings and found.feasible is not False, errors=[],
                      findings=found.findings, problem=problem, feasible=found.feasible,
                      conflict=found.conflict)


