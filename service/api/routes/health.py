"""Health: /healthz (the process answers) and /readyz (jobs are accepted and dispatched)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from floorplan.service.api.deps import BackendDep, LimitsDep, TrustedDep

router = APIRouter(tags=["service"])

#: What /readyz shows only to a caller with a valid key when keys are set: the
#: service's load, which is nobody else's business.
FIGURES = ("running", "queued", "workers", "store")


@router.get("/healthz")
def healthz() -> dict[str, str]:
    """The process answers."""
    return {"status": "ok"}


@router.get("/readyz")
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
