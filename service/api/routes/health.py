"""Health: /healthz (the process answers) and /readyz (jobs are accepted and dispatched)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from service.api.deps import BackendDep

router = APIRouter(tags=["service"])


@router.get("/healthz")
def healthz() -> dict[str, str]:
    """The process answers."""
    return {"status": "ok"}


@router.get("/readyz")
def readyz(backend: BackendDep) -> JSONResponse:
    """The store answers and jobs are dispatched (with the Celery backend, `broker`
    says whether Redis answers; jobs accepted meanwhile wait in the store)."""
    try:
        health = backend.health()
    except Exception as err:  # the store is away
        health = {"ready": False, "error": type(err).__name__}
    ok = bool(health.pop("ready"))
    return JSONResponse({"status": "ready" if ok else "not ready", **health},
                        status_code=200 if ok else 503)
