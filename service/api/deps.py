"""What routes depend on: the settings, the job backend and its store, the caller (by
its API key) and the caller's job; each with its `Annotated` alias for route signatures."""

from __future__ import annotations

import hashlib
import hmac
from typing import Annotated
from uuid import UUID

from fastapi import Depends, Path, Request
from fastapi.security import APIKeyHeader, HTTPAuthorizationCredentials, HTTPBearer

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


#: The two ways of giving a key, as OpenAPI security schemes: neither refuses a request
#: by itself (keys may be off); `owner_dep` does.
bearer = HTTPBearer(auto_error=False, scheme_name="bearerAuth",
                    description="Authorization: Bearer KEY (FLOORPLAN_API_KEYS)")
api_key_header = APIKeyHeader(name="X-API-Key", auto_error=False, scheme_name="apiKeyAuth",
                              description="X-API-Key: KEY, the same keys")
BearerDep = Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]
ApiKeyDep = Annotated[str | None, Depends(api_key_header)]


def _given_key(authorization: HTTPAuthorizationCredentials | None,
               x_api_key: str | None) -> str | None:
    """The key a request carries: `Authorization: Bearer KEY`, else `X-API-Key`."""
    if authorization is not None and authorization.credentials.strip():
        return authorization.credentials.strip()
    return x_api_key


def _valid(settings: Settings, key: str | None) -> bool:
    return bool(key) and any(hmac.compare_digest(key.encode(), known.encode())
                             for known in settings.api_keys)


def owner_dep(settings: SettingsDep, authorization: BearerDep, x_api_key: ApiKeyDep) -> str:
    """The caller's identity: a digest of its API key ("" when keys are off)."""
    if not settings.api_keys:
        return ""
    key = _given_key(authorization, x_api_key)
    if key is None or not _valid(settings, key):
        raise ApiError(401, "a valid API key is required (Authorization: Bearer KEY)",
                       kind="unauthorized", headers={"WWW-Authenticate": "Bearer"})
    return hashlib.sha256(key.encode()).hexdigest()[:32]


OwnerDep = Annotated[str, Depends(owner_dep)]


def trusted_dep(settings: SettingsDep, authorization: BearerDep, x_api_key: ApiKeyDep) -> bool:
    """Whether the caller may see the service's figures (/readyz): always when keys are
    off, else only with a valid key. Never refuses: readiness itself stays public."""
    return not settings.api_keys or _valid(settings, _given_key(authorization, x_api_key))


TrustedDep = Annotated[bool, Depends(trusted_dep)]


JobId = Annotated[str, Path(max_length=100, description="the job's id (a UUID)",
                            examples=["0b5c3f5e-8a8e-4d0e-9c55-3f1f0a3f2d11"])]


def job_dep(job_id: JobId, store: StoreDep, owner: OwnerDep) -> Job:
    """The caller's job, or 404: also for another key's job (ids do not leak), and for
    an id that is no UUID, which no job has (not a 422: the resource is what is
    missing, as clients expect of a GET by id)."""
    try:
        canonical = str(UUID(job_id))
    except ValueError:
        canonical = None
    # Without a batch layout's problem, derived from its batch's brief at some cost:
    # the routes that need it (exports) ask the store for it (JobStore.with_problem).
    job = None if canonical is None else store.get(canonical, owner, problem=False)
    if job is None:
        raise ApiError(404, f"job {job_id} not found", kind="job-not-found")
    return job


JobDep = Annotated[Job, Depends(job_dep)]
