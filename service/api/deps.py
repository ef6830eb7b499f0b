"""What routes depend on: the settings, the job backend and its store, the caller (by
its API key) and the caller's job; each with its `Annotated` alias for route signatures."""

from __future__ import annotations

import hashlib
import hmac
from typing import Annotated
from uuid import UUID

from fastapi import Depends, Header, Request

from floorplan.service.api.errors import ApiError
from floorplan.service.api.limits import Limits
from floorplan.service.jobs.backend import JobBackend
from floorplan.service.records import Job
from floorplan.service.settings import Settings
from floorplan.service.store import JobStore


def settings_dep(request: Request) -> Settings:
    return request.app.state.settings


def backend_dep(request: Request) -> JobBackend:
    return request.app.state.backend


def store_dep(request: Request) -> JobStore:
    return request.app.state.backend.store


def limits_dep(request: Request) -> Limits:
    return request.app.state.limits


SettingsDep = Annotated[Settings, Depends(settings_dep)]
LimitsDep = Annotated[Limits, Depends(limits_dep)]
StoreDep = Annotated[JobStore, Depends(store_dep)]
BackendDep = Annotated[JobBackend, Depends(backend_dep)]


def _given_key(authorization: str | None, x_api_key: str | None) -> str | None:
    """The key a request carries: `Authorization: Bearer KEY`, else `X-API-Key`."""
    if authorization and authorization.lower().startswith("bearer "):
        return authorization[7:].strip()
    return x_api_key


def _valid(settings: Settings, key: str | None) -> bool:
    return bool(key) and any(hmac.compare_digest(key.encode(), known.encode())
                             for known in settings.api_keys)


def owner_dep(
    settings: SettingsDep,
    authorization: Annotated[str | None, Header()] = None,
    x_api_key: Annotated[str | None, Header()] = None,
) -> str:
    """The caller's identity: a digest of its API key ("" when keys are off)."""
    if not settings.api_keys:
        return ""
    key = _given_key(authorization, x_api_key)
    if key is None or not _valid(settings, key):
        raise ApiError(401, "a valid API key is required (Authorization: Bearer KEY)",
                       kind="unauthorized", headers={"WWW-Authenticate": "Bearer"})
    return hashlib.sha256(key.encode()).hexdigest()[:32]


OwnerDep = Annotated[str, Depends(owner_dep)]


def trusted_dep(
    settings: SettingsDep,
    authorization: Annotated[str | None, Header()] = None,
    x_api_key: Annotated[str | None, Header()] = None,
) -> bool:
    """Whether the caller may see the service's figures (/readyz): always when keys are
    off, else only with a valid key. Never refuses: readiness itself stays public."""
    return not settings.api_keys or _valid(settings, _given_key(authorization, x_api_key))


TrustedDep = Annotated[bool, Depends(trusted_dep)]


def job_dep(job_id: UUID, store: StoreDep, owner: OwnerDep) -> Job:
    """The caller's job, or 404 (also for another key's job: ids do not leak)."""
    job = store.get(str(job_id), owner)
    if job is None:
        raise ApiError(404, f"job {job_id} not found", kind="job-not-found")
    return job


JobDep = Annotated[Job, Depends(job_dep)]
