"""The HTTP API: asynchronous layout jobs (submit, follow, fetch, cancel, delete, list),
validation without solving, health. Routes validate, delegate and reply; solving is
the job backend's (embedded or Celery, service/jobs/), geometry the solver's."""

from __future__ import annotations

import asyncio
import base64
import hashlib
import json
import threading
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from datetime import UTC, datetime
from typing import Annotated, Any, Literal
from uuid import UUID

from fastapi import APIRouter, Depends, FastAPI, Header, Query, Request, Response
from fastapi.openapi.utils import get_openapi
from fastapi.responses import JSONResponse, StreamingResponse
from pydantic import BaseModel, Field, ValidationError

from models import ConflictSet, Layout
from models import Problem as LayoutProblem
from models.templates import TemplatedProblem
from service import web
from service.errors import ApiError, FieldError, ProblemDetails, field_errors, install
from service.jobs.backend import JobBackend
from service.jobs.factory import make_backend
from service.settings import Settings, get_settings
from service.store import IdempotencyConflict, Job, JobStatus, JobStore
from solver.export import MEDIA_TYPES, render
from solver.geometry import make_domain
from solver.pipeline.storeys import job_time_limit
from solver.verify.conflicts import Diagnosis, diagnose
from solver.verify.precheck import find_impossibilities

#: Longest wait between two looks at the store while streaming events (the backend
#: wakes the stream sooner when it knows of new events).
STREAM_POLL = 1.0
#: Seconds between keep-alive comments on a quiet event stream.
HEARTBEAT = 15.0
#: Retry-After (seconds) suggested when the queue is full.
RETRY_AFTER = 5
#: Seconds POST /v1/validate?explain=true spends by default, and at most (never more
#: than FLOORPLAN_MAX_TIME_LIMIT either).
EXPLAIN_SECONDS = 3.0
EXPLAIN_MAX_SECONDS = 30.0
#: Explaining validations at once: their SCIP checks run in this process, so a burst
#: of them must not take every core from the solves.
EXPLAINS_AT_ONCE = 2
_explaining = threading.BoundedSemaphore(EXPLAINS_AT_ONCE)

EXAMPLE_PROBLEM: dict[str, Any] = {
    "name": "studio",
    "boundary": [[0, 0], [8, 0], [8, 6], [0, 6]],
    "entrance": [4, 0],
    "rooms": [
        {"id": "living", "type": "living", "min_size": [3, 3], "max_size": [6, 5],
         "target_size": [5, 4], "positions": [[4, 0.5]]},
        {"id": "bed", "type": "bedroom", "min_size": [2.5, 2.5], "max_size": [4, 4],
         "target_size": [3, 3], "boundary": ["north"]},
        {"id": "bath", "type": "bathroom", "min_size": [1.5, 1.5], "max_size": [3, 3],
         "target_size": [2, 2]},
    ],
    "adjacency": [{"a": "living", "b": "bed"}, {"a": "bed", "b": "bath"}],
    "options": {"time_limit": 5, "seed": 0},
}
#: The same flat from its room types alone: the residential template fills in the rest.
EXAMPLE_TEMPLATED: dict[str, Any] = {
    "name": "studio",
    "boundary": [[0, 0], [8, 0], [8, 6], [0, 6]],
    "entrance": [4, 0],
    "template": "residential",
    "rooms": ["living", "bedroom", "bathroom"],
    "options": {"time_limit": 5, "seed": 0},
}


# Response bodies.


class Progress(BaseModel):
    """The latest progress of a running solve."""

    phase: str | None = None
    level: int | None = None
    subdomain: int | None = None
    subdomains: int | None = None
    objective: float | None = Field(None, description="Eq. 12 of the incumbent layout")
    dual_bound: float | None = None
    elapsed: float | None = Field(None, description="seconds since the solve started")
    detail: str | None = None


class JobError(BaseModel):
    code: str
    message: str
    findings: list[str] = Field(default_factory=list)
    conflict: ConflictSet | None = Field(
        None, description="for an infeasible problem: a small set of its constraints that "
        "cannot hold together, by path and in words")


class JobPublic(BaseModel):
    """A layout job as clients see it."""

    id: UUID
    status: JobStatus
    termination: str | None = Field(None, description="optimal, timelimit, stalled, "
                                    "infeasible, interrupted, no_solution; set when the job ends")
    progress: Progress | None = None
    error: JobError | None = None
    attempts: int
    time_limit: float
    created_at: datetime
    started_at: datetime | None = None
    finished_at: datetime | None = None

    @classmethod
    def of(cls, job: Job) -> JobPublic:
        return cls(
            id=UUID(job.id), status=job.status, termination=job.termination,
            progress=Progress(**job.progress) if job.progress else None,
            error=JobError(**job.error) if job.error else None, attempts=job.attempts,
            time_limit=job.time_limit, created_at=_time(job.created_at),
            started_at=_time(job.started_at), finished_at=_time(job.finished_at),
        )


class JobPage(BaseModel):
    data: list[JobPublic]
    next_cursor: str | None = Field(None, description="pass as ?cursor= for the next page")


class Validation(BaseModel):
    """What POST /v1/validate finds without solving."""

    valid: bool = Field(description="well formed and no cheap impossibility found")
    errors: list[FieldError] = Field(default_factory=list)
    findings: list[str] = Field(default_factory=list,
                                description="reasons no layout can exist")
    problem: LayoutProblem | None = Field(
        None, description="the problem as it would be solved, a template expanded: the "
        "fields given or filled in (defaults left out); edit it and send it as is. "
        "Absent when the problem is not well formed")
    feasible: bool | None = Field(
        None, description="with explain: true when SCIP found a layout meeting every hard "
        "constraint, false when it proved there is none, null when neither in the time "
        "given; absent without explain")
    conflict: ConflictSet | None = Field(
        None, description="with explain, when no layout can exist: a small set of the "
        "problem's constraints that cannot hold together, by path and in words")


def _time(epoch: float | None) -> datetime | None:
    return datetime.fromtimestamp(epoch, UTC) if epoch is not None else None


# Dependencies.


def settings_dep(request: Request) -> Settings:
    return request.app.state.settings


def backend_dep(request: Request) -> JobBackend:
    return request.app.state.backend


def store_dep(request: Request) -> JobStore:
    return request.app.state.backend.store


SettingsDep = Annotated[Settings, Depends(settings_dep)]
StoreDep = Annotated[JobStore, Depends(store_dep)]
BackendDep = Annotated[JobBackend, Depends(backend_dep)]


def owner_dep(
    settings: SettingsDep,
    authorization: Annotated[str | None, Header()] = None,
    x_api_key: Annotated[str | None, Header()] = None,
) -> str:
    """The caller's identity: a digest of its API key ("" when keys are off)."""
    if not settings.api_keys:
        return ""
    key = x_api_key
    if authorization and authorization.lower().startswith("bearer "):
        key = authorization[7:].strip()
    if not key or key not in settings.api_keys:
        raise ApiError(401, "a valid API key is required (Authorization: Bearer KEY)",
                       kind="unauthorized", headers={"WWW-Authenticate": "Bearer"})
    return hashlib.sha256(key.encode()).hexdigest()[:32]


OwnerDep = Annotated[str, Depends(owner_dep)]


def job_dep(job_id: UUID, store: StoreDep, owner: OwnerDep) -> Job:
    """The caller's job, or 404 (also for another key's job: ids do not leak)."""
    job = store.get(str(job_id), owner)
    if job is None:
        raise ApiError(404, f"job {job_id} not found", kind="job-not-found")
    return job


JobDep = Annotated[Job, Depends(job_dep)]


async def problem_body(request: Request, settings: SettingsDep) -> tuple[LayoutProblem, bytes]:
    """The request body as a validated problem, within the size limit."""
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > settings.max_body_bytes:
        raise ApiError(413, f"the body exceeds {settings.max_body_bytes} bytes",
                       kind="body-too-large")
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > settings.max_body_bytes:
            raise ApiError(413, f"the body exceeds {settings.max_body_bytes} bytes",
                           kind="body-too-large")
    try:
        data = json.loads(body)
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ApiError(400, f"the body is not JSON: {err}", kind="malformed-json") from err
    try:
        problem = LayoutProblem.model_validate(data, context={"max_rooms": settings.max_rooms})
    except ValidationError as err:
        errors = field_errors(err.errors())
        raise ApiError(422, f"{len(errors)} invalid field(s)", kind="invalid-problem",
                       errors=errors) from err
    limit = problem.options.time_limit
    if limit is not None and limit > settings.max_time_limit:
        raise ApiError(422, f"time_limit may be at most {settings.max_time_limit} s",
                       kind="invalid-problem", errors=[FieldError(
                           field="options.time_limit", loc=["options", "time_limit"],
                           message=f"at most {settings.max_time_limit}", type="less_than_equal",
                       )])
    return problem, bytes(body)


ProblemBody = Annotated[tuple[LayoutProblem, bytes], Depends(problem_body)]
PROBLEM_BODY_DOC: dict[str, Any] = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {
            # A plain problem, or one a template fills in from its room types.
            "schema": {"anyOf": [{"$ref": "#/components/schemas/Problem"},
                                 {"$ref": "#/components/schemas/TemplatedProblem"}]},
            "examples": {
                "plain": {"summary": "every constraint stated", "value": EXAMPLE_PROBLEM},
                "templated": {"summary": "room types only (residential template)",
                              "value": EXAMPLE_TEMPLATED},
            },
        }},
    }
}


# Routes.

layouts = APIRouter(prefix="/v1/layouts", tags=["layouts"])


@layouts.post("", status_code=202, response_model=JobPublic, openapi_extra=PROBLEM_BODY_DOC,
              responses={409: {"description": "Idempotency-Key reused with another body"},
                         413: {"description": "body too large"},
                         422: {"description": "invalid problem"},
                         429: {"description": "queue full"}})
def submit_layout(
    body: ProblemBody, response: Response, store: StoreDep, backend: BackendDep,
    settings: SettingsDep, owner: OwnerDep,
    idempotency_key: Annotated[str | None, Header(max_length=200)] = None,
) -> JobPublic:
    """Queue a layout job. The answer names it in `Location`; follow it with
    GET /v1/layouts/{id}, its event stream, or its result."""
    problem, raw = body
    if store.count(JobStatus.QUEUED) >= settings.queue_limit:
        raise ApiError(429, "the queue is full; try again later", kind="queue-full",
                       headers={"Retry-After": str(RETRY_AFTER)})
    time_limit = job_time_limit(problem)  # a building's floors each have their share
    digest = hashlib.sha256(
        json.dumps(json.loads(raw), sort_keys=True, separators=(",", ":")).encode()
    ).hexdigest()
    try:
        job, new = store.create(problem=problem.model_dump_json(), time_limit=time_limit,
                                 owner=owner, idempotency_key=idempotency_key, body_hash=digest)
    except IdempotencyConflict as err:
        raise ApiError(409, "this Idempotency-Key was used with another body",
                       kind="idempotency-conflict") from err
    if new:
        backend.submitted(job)
    response.headers["Location"] = f"/v1/layouts/{job.id}"
    return JobPublic.of(job)


@layouts.get("", response_model=JobPage)
def list_layouts(
    store: StoreDep, owner: OwnerDep,
    status: JobStatus | None = None,
    limit: Annotated[int, Query(ge=1, le=200)] = 50,
    cursor: str | None = None,
) -> JobPage:
    """The caller's jobs, newest first, a page at a time."""
    after = _decode_cursor(cursor) if cursor else None
    found = store.list(owner=owner, status=status, limit=limit + 1, after=after)
    page, more = found[:limit], len(found) > limit
    next_cursor = _encode_cursor(page[-1]) if more and page else None
    return JobPage(data=[JobPublic.of(j) for j in page], next_cursor=next_cursor)


@layouts.get("/{job_id}", response_model=JobPublic, responses={404: {"description": "unknown"}})
def get_layout(job: JobDep) -> JobPublic:
    """Status, termination, progress and timestamps of a job."""
    return JobPublic.of(job)


@layouts.get("/{job_id}/result", response_model=Layout,
             responses={200: {"content": {MEDIA_TYPES[f]: {} for f in ("svg", "dxf", "geojson")}},
                        404: {"description": "unknown job, or no layout yet"}})
def get_result(
    job: JobDep, format: Literal["json", "svg", "dxf", "geojson"] = "json"
) -> Response:
    """The layout: the final one, or the best so far while the job runs; as JSON, an
    SVG plan, a DXF drawing (metres) or GeoJSON (local metric frame)."""
    text = job.result or job.incumbent
    if text is None:
        raise ApiError(404, f"job {job.id} has no layout yet (status {job.status})",
                       kind="no-result-yet", title="No layout yet")
    if format == "json":
        return Response(text, media_type=MEDIA_TYPES["json"])
    problem = LayoutProblem.model_validate_json(job.problem)
    body = render(problem, Layout.model_validate_json(text), format)
    # A plan shows in the browser; drawings and data download as files.
    disposition = "inline" if format == "svg" else "attachment"
    headers = {"Content-Disposition": f'{disposition}; filename="{job.id}.{format}"'}
    return Response(body, media_type=MEDIA_TYPES[format], headers=headers)


@layouts.get("/{job_id}/events", responses={200: {"content": {"text/event-stream": {}}}})
async def stream_events(
    job: JobDep, backend: BackendDep,
    last_event_id: Annotated[str | None, Header()] = None,
) -> StreamingResponse:
    """Server-Sent Events: `status`, `progress`, `incumbent` (with the incumbent layout).
    Each event's id works as Last-Event-ID to resume; progress and incumbents come at
    most twice a second, always the newest. The stream ends with the job."""
    after = int(last_event_id) if last_event_id and last_event_id.isdigit() else 0
    return StreamingResponse(_events(backend, job.id, after), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})


async def _events(backend: JobBackend, job_id: str, after: int) -> AsyncIterator[str]:
    store = backend.store
    quiet_since = time.monotonic()
    while True:
        batch = await asyncio.to_thread(store.events_after, job_id, after)
        for e in batch:
            after = e.seq
            yield f"id: {e.seq}\nevent: {e.kind}\ndata: {e.data}\n\n"
        if batch:
            quiet_since = time.monotonic()
        job = await asyncio.to_thread(store.get, job_id)
        if job is None or (job.status.terminal and not batch):
            return
        if time.monotonic() - quiet_since > HEARTBEAT:
            quiet_since = time.monotonic()
            yield ": keep-alive\n\n"
        await backend.wait_for_events(job_id, STREAM_POLL)


@layouts.post("/{job_id}/cancel", response_model=JobPublic)
def cancel_layout(job: JobDep, backend: BackendDep, store: StoreDep) -> JobPublic:
    """Stop the solve gracefully; the best layout so far becomes the result. Cancelling
    a finished job changes nothing."""
    if not job.status.terminal:
        backend.cancel(job.id)
    current = store.get(job.id)
    assert current is not None
    return JobPublic.of(current)


@layouts.delete("/{job_id}", status_code=204, responses={409: {"description": "still running"}})
def delete_layout(job: JobDep, store: StoreDep) -> Response:
    """Remove a finished job and its data."""
    if not job.status.terminal:
        raise ApiError(409, f"job {job.id} is {job.status}; cancel it first",
                       kind="job-not-finished")
    store.delete(job.id)
    return Response(status_code=204)


misc = APIRouter(tags=["service"])


@misc.post("/v1/validate", response_model=Validation, openapi_extra=PROBLEM_BODY_DOC,
           response_model_exclude_unset=True)
async def validate_problem(
    request: Request, settings: SettingsDep,
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
        problem, _raw = await problem_body(request, settings)
    except ApiError as err:
        if err.status != 422:
            raise
        return Validation(valid=False, errors=err.errors or [], findings=[])
    if not explain:
        findings = await asyncio.to_thread(find_impossibilities, problem, make_domain(problem))
        # exclude_unset on the answer: the problem shows what was given or filled in.
        return Validation(valid=not findings, errors=[], findings=findings, problem=problem)
    seconds = min(time_limit, settings.max_time_limit)
    found = await asyncio.to_thread(_diagnose, problem, seconds)
    return Validation(valid=not found.findings and found.feasible is not False, errors=[],
                      findings=found.findings, problem=problem, feasible=found.feasible,
                      conflict=found.conflict)


def _diagnose(problem: LayoutProblem, seconds: float) -> Diagnosis:
    with _explaining:
        return diagnose(problem, time_limit=seconds)


@misc.get("/healthz")
def healthz() -> dict[str, str]:
    """The process answers."""
    return {"status": "ok"}


@misc.get("/readyz")
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


def _encode_cursor(job: Job) -> str:
    return base64.urlsafe_b64encode(json.dumps([job.created_at, job.id]).encode()).decode()


def _decode_cursor(cursor: str) -> tuple[float, str]:
    try:
        created, job_id = json.loads(base64.urlsafe_b64decode(cursor.encode()))
        return float(created), str(job_id)
    except (ValueError, TypeError) as err:
        raise ApiError(400, "the cursor is not one this service gave out",
                       kind="bad-cursor") from err


# The application.


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        backend = await asyncio.to_thread(make_backend, settings)
        app.state.settings, app.state.backend = settings, backend
        backend.start()
        try:
            yield
        finally:
            await backend.aclose()
            await asyncio.to_thread(backend.stop)

    app = FastAPI(
        title="floorplan", version="0.1.0", lifespan=lifespan,
        description="Interior layouts as asynchronous jobs: post a problem, follow the job, "
        "fetch the layout. Errors are RFC 9457 problem documents.",
    )
    install(app)
    app.include_router(layouts)
    app.include_router(misc)
    web.install(app)  # the page at /, its static files, the examples
    app.openapi = lambda: _openapi(app)  # type: ignore[method-assign]
    return app


def _openapi(app: FastAPI) -> dict[str, Any]:
    """FastAPI's schema plus the Problem model the hand-validated bodies refer to."""
    if app.openapi_schema:
        return app.openapi_schema
    schema = get_openapi(title=app.title, version=app.version, description=app.description,
                         routes=app.routes)
    components = schema.setdefault("components", {}).setdefault("schemas", {})
    for model, name in ((LayoutProblem, "Problem"), (TemplatedProblem, "TemplatedProblem"),
                        (ProblemDetails, "ProblemDetails")):
        model_schema = model.model_json_schema(ref_template="#/components/schemas/{model}")
        components.update(model_schema.pop("$defs", {}))
        components[name] = model_schema
    # Errors are problem documents (RFC 9457), FastAPI's own 422 included.
    problem_doc = {"application/problem+json": {
        "schema": {"$ref": "#/components/schemas/ProblemDetails"}}}
    for operation in (op for path in schema["paths"].values() for op in path.values()):
        responses = operation.setdefault("responses", {})
        for code, response in responses.items():
            if code[0] in "45":
                response["content"] = problem_doc
        responses.setdefault("default", {"description": "an error", "content": problem_doc})
    for unused in ("HTTPValidationError", "ValidationError"):
        components.pop(unused, None)
    app.openapi_schema = schema
    return schema
