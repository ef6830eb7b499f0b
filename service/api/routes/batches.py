"""Batches (/v1/batches; docs/service.md, "Endpoints"): one brief laid out many times,
each layout an ordinary job of the store (so the embedded runner and the Celery workers
solve them as any job, a restart requeues what was running and keeps what is done), made
in one transaction with the batch's row."""

from __future__ import annotations

import io
import json
import re
import zipfile
from collections.abc import Iterator
from datetime import UTC, datetime
from typing import Annotated, Literal

from fastapi import APIRouter, Query, Request, Response
from fastapi.responses import StreamingResponse

from floorplan.models import Layout
from floorplan.models.jobs import (
    MAX_BATCH_COUNT,
    BatchLayoutLine,
    BatchPublic,
    JobError,
    JobStatus,
)
from floorplan.service.api.body import BATCH_BODY_DOC, BatchBody
from floorplan.service.api.deps import BackendDep, OwnerDep, SettingsDep, StoreDep
from floorplan.service.api.errors import STORE_RETRY_AFTER, ApiError
from floorplan.service.api.limits import quota, refusal
from floorplan.service.batch import GOOD_COVERAGE, layout_problem
from floorplan.service.records import Batch, BatchLayout
from floorplan.service.store import JobStore, QuotaExceeded

NDJSON = "application/x-ndjson"
ZIP = "application/zip"
#: The zip's list of the page's lines (NDJSON, without layouts).
ZIP_INDEX = "results.ndjson"
#: What a layout's file name in a zip keeps of the batch's name.
_SAFE_NAME = re.compile(r"[^A-Za-z0-9._-]+")

#: Most lines one page of results holds.
MAX_PAGE = 500
DEFAULT_PAGE = 100

router = APIRouter(prefix="/v1/batches", tags=["batches"])


def batch_or_404(batch_id: str, store: StoreDep, owner: OwnerDep) -> Batch:
    batch = store.get_batch(batch_id, owner)
    if batch is None:
        raise ApiError(404, f"batch {batch_id} not found", kind="not-found")
    return batch


@router.post("", status_code=202, response_model=BatchPublic, openapi_extra=BATCH_BODY_DOC,
             responses={401: {"description": "API keys are set and none valid was given"},
                        413: {"description": "the body, or the brief's outline, obstacles "
                              "or regions, larger than the service takes"},
                        415: {"description": "the body not sent as application/json"},
                        422: {"description": "invalid brief"},
                        429: {"description": "the queue cannot take the batch"}})
def submit_batch(
    body: BatchBody, response: Response, store: StoreDep, backend: BackendDep,
    settings: SettingsDep, owner: OwnerDep,
) -> BatchPublic:
    """Queue `count` layouts of the brief, seeds `seed`, `seed` + 1, ..., each solved with
    options.diverse and options.stop_when_good (and with `vary_program` its own
    programme). Follow it with GET /v1/batches/{id} and its results."""
    # The body was read after the key, within the size limit, and the brief checked as
    # any job's body (docs/security.md, "The limits"), off the event loop (BatchBody).
    unwritable = store.unwritable()
    if unwritable is not None:  # accepted, the layouts would be lost: nothing is taken
        raise ApiError(503, f"the job store cannot take jobs now: {unwritable}",
                       kind="store-unavailable", headers={"Retry-After": str(STORE_RETRY_AFTER)})
    # The brief is stored once, in the batch's row; each layout's problem is derived
    # from it when its job is read (service.batch.layout_problem). The first layout's
    # is derived here: a brief that cannot give one is refused now, not layout by
    # layout, and its limit stands for the jobs' until then.
    brief = json.dumps(body.problem, separators=(",", ":"))
    _, first_limit = layout_problem(brief, body.seed, body.time_limit, body.vary_program,
                                    settings.max_time_limit)
    name = body.name or str(body.problem.get("name") or "batch")
    stored = len(brief.encode())
    if stored > settings.max_batch_bytes:
        raise ApiError(413, f"the batch's brief takes {stored} bytes, more than "
                       f"{settings.max_batch_bytes} (FLOORPLAN_MAX_BATCH_BYTES); send a "
                       "smaller brief", kind="batch-too-large")
    try:  # the limits counted in the transaction that inserts the batch
        batch, made = store.create_batch(
            owner=owner, name=name[:200], seed=body.seed, vary_program=body.vary_program,
            brief=brief, count=body.count, time_limit=body.time_limit,
            time_ceiling=settings.max_time_limit, job_time_limit=first_limit,
            quota=quota(settings))
    except QuotaExceeded as err:
        raise refusal(err, body.count) from err
    for job in made:
        backend.submitted(job)
    response.headers["Location"] = f"/v1/batches/{batch.id}"
    return batch_public(store, batch)


@router.get("/{batch_id}", response_model=BatchPublic,
            responses={404: {"description": "unknown batch"}})
def get_batch(
    batch_id: str, store: StoreDep, owner: OwnerDep,
    summary: Annotated[bool, Query(description="also count valid layouts and distinct "
                                   "plans (reads every finished layout)")] = False,
) -> BatchPublic:
    """Progress: the batch's layouts by status; with ?summary=true the valid ones and the
    distinct plans and adjacency graphs among them."""
    return batch_public(store, batch_or_404(batch_id, store, owner), summary=summary)


#: The `after` and `limit` of a page of results.
After = Annotated[int, Query(ge=-1, lt=MAX_BATCH_COUNT, description="the last index "
                             "already read (a batch has at most 10,000 layouts)")]
Limit = Annotated[int, Query(ge=1, le=MAX_PAGE)]
_NEXT = ("a `Link: <...>; rel=\"next\"` header while more finished layouts may follow")


class Ndjson(StreamingResponse):
    media_type = NDJSON


class Zip(Response):
    media_type = ZIP


@router.get("/{batch_id}/results", response_class=Ndjson, responses={
    200: {"content": {NDJSON: {"schema": {"type": "string"}}},
          "description": "NDJSON (application/x-ndjson): one BatchLayoutLine per line; "
                         + _NEXT},
    404: {"description": "unknown batch"}})
def get_batch_results(
    batch_id: str, request: Request, store: StoreDep, owner: OwnerDep,
    after: After = -1, limit: Limit = DEFAULT_PAGE,
    layouts: Annotated[bool, Query(description="false: the lines without their "
                                   "layouts")] = True,
    # The older spelling of getBatchResultsZip, with `Accept: application/zip`.
    fmt: Annotated[Literal["ndjson", "zip"] | None, Query(
        alias="format", include_in_schema=False)] = None,
) -> Response:
    """The finished layouts, in index order, a page at a time, as NDJSON lines."""
    if fmt is None:
        fmt = "zip" if _accepts_zip(request.headers.get("accept", "")) else "ndjson"
    if fmt == "zip":
        return get_batch_results_zip(batch_id, request, store, owner, after, limit)
    batch = batch_or_404(batch_id, store, owner)
    found = store.batch_layouts(batch.id, after=after, limit=limit)

    def lines() -> Iterator[str]:
        for item in found:
            line = _line(batch, item, with_layout=layouts)
            yield line.model_dump_json(exclude_none=True) + "\n"

    return Ndjson(lines(), headers=_next_link(request, found, limit))


@router.get("/{batch_id}/results/zip", response_class=Zip, responses={
    200: {"content": {ZIP: {"schema": {"type": "string", "format": "binary"}}},
          "description": "a zip of the page's layouts (one NAME-SEED.json each) and its "
                         "lines without layouts (results.ndjson); " + _NEXT},
    404: {"description": "unknown batch"}})
def get_batch_results_zip(
    batch_id: str, request: Request, store: StoreDep, owner: OwnerDep,
    after: After = -1, limit: Limit = DEFAULT_PAGE,
) -> Response:
    """A page of finished layouts, in index order, as a zip."""
    batch = batch_or_404(batch_id, store, owner)
    found = store.batch_layouts(batch.id, after=after, limit=limit)
    headers = _next_link(request, found, limit)
    name = f"batch-{batch.id}-after-{after}.zip"
    headers["Content-Disposition"] = f'attachment; filename="{name}"'
    return Zip(_zip_page(batch, found), headers=headers)


def _next_link(request: Request, found: list[BatchLayout], limit: int) -> dict[str, str]:
    """The `Link` header to the next page, when this one is full."""
    if len(found) < limit:
        return {}
    url = request.url.include_query_params(after=found[-1].index, limit=limit)
    return {"Link": f'<{url}>; rel="next"'}


def _accepts_zip(accept: str) -> bool:
    """Whether an Accept header names application/zip (with any parameters)."""
    return any(part.split(";")[0].strip().lower() == ZIP for part in accept.split(","))


def _line(batch: Batch, item: BatchLayout, *, with_layout: bool) -> BatchLayoutLine:
    layout = Layout.model_validate_json(item.result) if item.result else None
    report = layout.report if layout is not None else None
    return BatchLayoutLine(
        index=item.index, seed=batch.seed + item.index, job_id=item.job_id,
        status=item.status, termination=item.termination,
        valid=None if report is None else report.valid,
        coverage=None if report is None else report.coverage,
        objective=None if report is None else report.objective,
        solve_time=None if report is None else report.solve_time,
        layout=layout if with_layout else None,
        error=JobError(**item.error) if item.error else None)


def _zip_page(batch: Batch, found: list[BatchLayout]) -> bytes:
    """A page of results as a zip: each layout's JSON as the job stored it, named as
    `floorplan batch` names its files (NAME-SEED.json), and every line of the page
    without its layout, failed and canceled ones too, in results.ndjson."""
    stem = _SAFE_NAME.sub("_", batch.name).strip("._") or "batch"
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        index_lines = []
        for item in found:
            line = _line(batch, item, with_layout=False)
            index_lines.append(line.model_dump_json(exclude_none=True) + "\n")
            if item.result:
                archive.writestr(f"{stem}-{line.seed:06d}.json", item.result)
        archive.writestr(ZIP_INDEX, "".join(index_lines))
    return buffer.getvalue()


@router.post("/{batch_id}/cancel", response_model=BatchPublic,
             responses={404: {"description": "unknown batch"}})
def cancel_batch(batch_id: str, store: StoreDep, backend: BackendDep,
                 owner: OwnerDep) -> BatchPublic:
    """Cancel every layout not yet finished (queued ones at once, running ones stop and
    keep their best layout); finished layouts stay."""
    batch = batch_or_404(batch_id, store, owner)
    for job_id in store.batch_unfinished(batch.id):
        backend.cancel(job_id)
    return batch_public(store, batch)


def batch_public(store: JobStore, batch: Batch, *, summary: bool = False) -> BatchPublic:
    counts = store.batch_counts(batch.id)
    n = {status: counts.get(status, 0) for status in JobStatus}
    if n[JobStatus.QUEUED] + n[JobStatus.RUNNING] == 0:
        status = (JobStatus.CANCELED if n[JobStatus.CANCELED] else JobStatus.FAILED
                  if n[JobStatus.FAILED] else JobStatus.SUCCEEDED)
    elif n[JobStatus.QUEUED] == batch.count:
        status = JobStatus.QUEUED
    else:
        status = JobStatus.RUNNING
    valid = plans = graphs = None
    if summary:
        valid, plans, graphs = _summary(store, batch)
    return BatchPublic(
        id=batch.id, name=batch.name, count=batch.count, seed=batch.seed,
        vary_program=batch.vary_program, status=status, queued=n[JobStatus.QUEUED],
        running=n[JobStatus.RUNNING], succeeded=n[JobStatus.SUCCEEDED],
        failed=n[JobStatus.FAILED], canceled=n[JobStatus.CANCELED], valid=valid,
        distinct_plans=plans, distinct_graphs=graphs,
        created_at=datetime.fromtimestamp(batch.created_at, UTC))


def _summary(store: JobStore, batch: Batch) -> tuple[int, int, int]:
    from floorplan.solver.distinct import DistinctPlans

    plans = DistinctPlans()
    valid, after = 0, -1
    while True:
        page = store.batch_layouts(batch.id, after=after, limit=MAX_PAGE)
        for item in page:
            if item.result is None:
                continue
            layout = Layout.model_validate_json(item.result)
            valid += layout.report.valid and layout.report.coverage >= GOOD_COVERAGE
            if layout.all_rooms:
                plans.add(layout)
        if len(page) < MAX_PAGE:
            return valid, plans.plans, plans.graphs
        after = page[-1].index
