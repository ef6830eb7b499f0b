"""The layout jobs (/v1/layouts): submit, list, status, events, cancel, delete (the
results are results.py)."""

from __future__ import annotations

import asyncio
import base64
import hashlib
import json
import time
from collections.abc import AsyncIterator
from typing import Annotated

from fastapi import APIRouter, Header, Query, Response
from fastapi.responses import StreamingResponse

from floorplan.models.jobs import JobStatus
from floorplan.service.api.body import PROBLEM_BODY_DOC, ProblemBody
from floorplan.service.api.deps import (
    BackendDep,
    JobDep,
    LimitsDep,
    OwnerDep,
    SettingsDep,
    StoreDep,
)
from floorplan.service.api.errors import STORE_RETRY_AFTER, ApiError
from floorplan.service.api.limits import quota, refusal
from floorplan.service.api.schemas import JobPage, JobPublic, job_public
from floorplan.service.jobs.backend import JobBackend
from floorplan.service.records import Job
from floorplan.service.store import IdempotencyConflict, QuotaExceeded
from floorplan.service.timing import effective_time_limit

#: Longest wait between two looks at the store while streaming events (the backend
#: wakes the stream sooner when it knows of new events).
STREAM_POLL = 1.0
#: Seconds between keep-alive comments on a quiet event stream.
HEARTBEAT = 15.0
#: Retry-After (seconds) suggested when the queue is full.
RETRY_AFTER = 5
#: A Last-Event-ID: the decimal digits of an event's sequence number, which fits a
#: signed 64-bit integer (or nothing).
EVENT_ID = r"^[0-9]{0,18}$"
#: The media type of the event stream.
EVENT_STREAM = "text/event-stream"
#: Longest cursor taken: the ones given out are about 80 characters.
CURSOR_MAX = 256



class EventStream(StreamingResponse):
    """A stream of Server-Sent Events."""

    media_type = EVENT_STREAM


router = APIRouter(prefix="/v1/layouts", tags=["layouts"])


@router.post("", status_code=202, response_model=JobPublic, openapi_extra=PROBLEM_BODY_DOC,
             responses={409: {"description": "Idempotency-Key reused with another body"},
                        413: {"description": "the body, or an outline, the obstacles "
                                   "or the regions, larger than the service takes"},
                        415: {"description": "the body not sent as application/json"},
                        422: {"description": "invalid problem"},
                        429: {"description": "the queue full, or this key's jobs at their "
                              "limit"},
                        503: {"description": "the job store cannot take jobs (full disk, "
                              "read-only)"}})
def submit_layout(
    body: ProblemBody, response: Response, store: StoreDep, backend: BackendDep,
    settings: SettingsDep, owner: OwnerDep,
    idempotency_key: Annotated[str | None, Header(max_length=200)] = None,
) -> JobPublic:
    """Queue a layout job. The answer names it in `Location`; follow it with
    GET /v1/layouts/{id}, its event stream, or its result."""
    problem, raw = body
    unwritable = store.unwritable()
    if unwritable is not None:  # accepted, the job would be lost: nothing is taken
        raise ApiError(503, f"the job store cannot take jobs now: {unwritable}",
                       kind="store-unavailable", headers={"Retry-After": str(STORE_RETRY_AFTER)})
    problem, time_limit = effective_time_limit(problem, settings.max_time_limit)
    digest = hashlib.sha256(
        json.dumps(json.loads(raw), sort_keys=True, separators=(",", ":")).encode()
    ).hexdigest()
    try:
        job, new = store.create(problem=problem.model_dump_json(), time_limit=time_limit,
                                 owner=owner, idempotency_key=idempotency_key, body_hash=digest,
                                 quota=quota(settings))
    except QuotaExceeded as err:  # counted in the transaction that would insert it
        raise refusal(err, 1) from err
    except IdempotencyConflict as err:
        raise ApiError(409, "this Idempotency-Key was used with another body",
                       kind="idempotency-conflict") from err
    if new:
        backend.submitted(job)
    response.headers["Location"] = f"/v1/layouts/{job.id}"
    return job_public(job)


@router.get("", response_model=JobPage,
            responses={400: {"description": "a cursor this service did not give out"}})
def list_layouts(
    store: StoreDep, owner: OwnerDep,
    status: JobStatus | None = None,
    limit: Annotated[int, Query(ge=1, le=200)] = 50,
    cursor: Annotated[str | None, Query(
        max_length=CURSOR_MAX, description="next_cursor of the previous page")] = None,
) -> JobPage:
    """The caller's jobs, newest first, a page at a time."""
    after = _decode_cursor(cursor) if cursor else None
    found = store.list(owner=owner, status=status, limit=limit + 1, after=after)
    page, more = found[:limit], len(found) > limit
    next_cursor = _encode_cursor(page[-1]) if more and page else None
    return JobPage(data=[job_public(j) for j in page], next_cursor=next_cursor)


@router.get("/{job_id}", response_model=JobPublic, responses={404: {"description": "unknown job"}})
def get_layout(job: JobDep) -> JobPublic:
    """Status, termination, progress and timestamps of a job."""
    return job_public(job)


@router.get("/{job_id}/events", response_class=EventStream, responses={
    200: {"description": "Server-Sent Events (text/event-stream), one `id:`, `event:` "
          "(status, progress or incumbent) and `data:` (a JSON object) each, and `: "
          "keep-alive` comments; the stream ends with the job",
          "content": {EVENT_STREAM: {"schema": {"type": "string"}}}},
    400: {"description": "Last-Event-ID past this job's last event"},
    404: {"description": "unknown job"},
    429: {"description": "open streams at their limit"}})
async def get_layout_events(
    job: JobDep, backend: BackendDep, store: StoreDep, owner: OwnerDep, limits: LimitsDep,
    last_event_id: Annotated[str | None, Header(
        pattern=EVENT_ID, description="resume after this event: the id of one this job's "
        "stream sent")] = None,
) -> StreamingResponse:
    """Server-Sent Events: `status`, `progress`, `incumbent` (with the incumbent layout).
    Each event's id works as Last-Event-ID to resume; progress and incumbents come at
    most twice a second, always the newest. The stream ends with the job. A
    Last-Event-ID that is not a number is a 422; one past the job's last event a 400."""
    after = 0
    if last_event_id:  # an empty one, as EventSource may send, is no id
        after = int(last_event_id)
        newest = await asyncio.to_thread(store.last_event, job.id)
        if after > newest:
            raise ApiError(400, f"Last-Event-ID {after} is past this job's last event "
                           f"({newest})", kind="bad-last-event-id")
    return EventStream(limits.stream(owner, _events(backend, job.id, after)),
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


@router.post("/{job_id}/cancel", response_model=JobPublic,
             responses={404: {"description": "unknown job"}})
def cancel_layout(job: JobDep, backend: BackendDep, store: StoreDep) -> JobPublic:
    """Stop the solve gracefully; the best layout so far becomes the result. Cancelling
    a finished job changes nothing."""
    if not job.status.terminal:
        backend.cancel(job.id)
    current = store.get(job.id)
    assert current is not None
    return job_public(current)


@router.delete("/{job_id}", status_code=204,
               responses={404: {"description": "unknown job"},
                          409: {"description": "still running"}})
def delete_layout(job: JobDep, store: StoreDep) -> Response:
    """Remove a finished job and its data."""
    if not job.status.terminal:
        raise ApiError(409, f"job {job.id} is {job.status}; cancel it first",
                       kind="job-not-finished")
    store.delete(job.id)
    return Response(status_code=204)


def _encode_cursor(job: Job) -> str:
    return base64.urlsafe_b64encode(json.dumps([job.created_at, job.id]).encode()).decode()


def _decode_cursor(cursor: str) -> tuple[float, str]:
    try:
        created, job_id = json.loads(base64.urlsafe_b64decode(cursor.encode()))
        if not isinstance(created, int | float) or not isinstance(job_id, str):
            raise TypeError(cursor)
        return float(created), job_id
    # ValueError: not base64, not UTF-8, not JSON, a number of thousands of digits;
    # RecursionError: JSON nested deeper than the parser goes.
    except (ValueError, TypeError, RecursionError) as err:
        raise ApiError(400, "the cursor is not one this service gave out",
                       kind="bad-cursor") from err
