"""Health: /healthz (the process answers) and /readyz (jobs are accepted and dispatched)."""

from __future__ import annotations

from typing import Literal

from fastapi import APIRouter
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field

from floorplan.service.api.deps import BackendDep, LimitsDep, TrustedDep

router = APIRouter(tags=["service"])

#: What /readyz shows only to a caller with a valid key when keys are set: the
#: service's load, which is nobody else's business.
FIGURES = ("running", "queued", "workers", "store")


class Health(BaseModel):
    """The process answers."""

    status: Literal["ok"]


class Readiness(BaseModel):
    """Whether jobs are accepted and dispatched, and (for a caller with a valid key when
    keys are set) the service's load."""

    status: Literal["ready", "not ready"]
    backend: str | None = Field(None, description="celery: the distributed mode")
    broker: str | None = Field(None, description="celery: 'ok' or 'down' (Redis)")
    store: str | None = Field(None, description="'ok', or why the store cannot take jobs")
    running: int | None = Field(None, description="jobs being solved")
    queued: int | None = Field(None, description="jobs waiting")
    workers: int | None = Field(None, description="celery: live workers")
    explain: str | None = Field(None, description="'replaced': the explain pool lost a "
                                "process and was replaced by this check")
    export: str | None = Field(None, description="'replaced': the export pool lost a "
                               "process and was replaced by this check")


@router.get("/healthz", response_model=Health)
def healthz() -> Health:
    """The process answers."""
    return Health(status="ok")


@router.get("/readyz", response_model=Readiness, responses={
    503: {"description": "not ready (the same body, `status` 'not ready')",
          "content": {"application/json": {"schema": {"$ref": "#/components/schemas/Readiness"}}}}})
def readyz(backend: BackendDep, limits: LimitsDep, trusted: TrustedDep) -> JSONResponse:
    """The store answers and takes writes, and jobs are dispatched (with the Celery
    backend, `broker` says whether Redis answers; jobs accepted meanwhile wait in the
    store). `store` says why the store cannot take jobs, if it cannot. The `running`,
    `queued`, `workers` and `store` figures need a valid key when keys are set. An
    explain or export pool that lost a process is not ready (`explain` or `export`:
    "replaced"): it is replaced by this very check, and the next answers ready again."""
    try:
        health = backend.health()
    except Exception as err:  # the store is away
        health = {"ready": False, "store": type(err).__name__}
    lost = limits.pools_ready()
    if lost:
        health["ready"] = False
        health.update(lost)
    ok = bool(health.pop("ready"))
    if not trusted:
        for figure in FIGURES:
            health.pop(figure, None)
    return JSONResponse({"status": "ready" if ok else "not ready", **health},
                        status_code=200 if ok else 503)
