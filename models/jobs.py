"""Layout jobs as the service's HTTP API shows them: the one definition of these bodies,
for the service that sends them and the Python client that reads them.

Reading ignores fields it does not know (``extra="ignore"``), so a newer service does
not break an older client; a body once read is a value (``frozen``). The JSON of each
model is what the service sent before this module existed, field for field, and the
class names are the names of the OpenAPI schema's components (the client exports
`JobPublic` as ``JobInfo`` and `JobError` as ``ErrorInfo``).
"""

from __future__ import annotations

import math
from datetime import datetime
from enum import StrEnum
from typing import Annotated, Any
from uuid import UUID

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

from .layout import ConflictSet, Layout, Termination
from .problem import Problem


class JobStatus(StrEnum):
    """Where a job is in its life."""

    QUEUED = "queued"
    """Accepted and waiting for a free solver."""
    RUNNING = "running"
    """Being solved; `JobPublic.progress` and the incumbent layout follow it."""
    SUCCEEDED = "succeeded"
    """Ended with a layout (check `report.valid` and `report.termination`)."""
    FAILED = "failed"
    """Ended without a layout: infeasible, nothing found in time, or the solver died;
    `JobPublic.error` says which."""
    CANCELED = "canceled"
    """Stopped on request; the best layout found by then, if any, is the result."""

    @property
    def terminal(self) -> bool:
        """True once the job has ended and will not change again."""
        return self in (JobStatus.SUCCEEDED, JobStatus.FAILED, JobStatus.CANCELED)


class WireModel(BaseModel):
    """A body of the API: unknown fields ignored, immutable once read."""

    model_config = ConfigDict(extra="ignore", frozen=True)


class Progress(WireModel):
    """The latest progress of a running solve."""

    phase: str | None = None
    level: int | None = None
    subdomain: int | None = None
    subdomains: int | None = None
    objective: float | None = Field(default=None, description="Eq. 12 of the incumbent layout")
    dual_bound: float | None = None
    elapsed: float | None = Field(default=None, description="seconds since the solve started")
    detail: str | None = None

    def __str__(self) -> str:
        """E.g. ``level 2 sub 1/3  objective 12.41  bound 3.20  elapsed 1.23 s``."""
        parts = []
        if self.level is not None:
            where = f"level {self.level}"
            if self.subdomains:
                where += f" sub {self.subdomain}/{self.subdomains}"
            parts.append(where)
        if self.objective is not None:
            parts.append(f"objective {format_number(self.objective)}")
        if self.dual_bound is not None:
            parts.append(f"bound {format_number(self.dual_bound)}")
        if self.elapsed is not None:
            parts.append(f"elapsed {self.elapsed:.2f} s")
        detail = (self.detail or "").removeprefix(f"level {self.level}: ")  # said already
        if detail:
            parts.append(detail)
        return "  ".join(parts) or (self.phase or "")


class JobError(WireModel):
    """Why a job failed: a code (``infeasible``, ``no_solution``, ``worker_died``,
    ``solver_error``, ``retries_exhausted``, ...), a message and, for an infeasible
    problem, the impossibilities found and the constraints that cannot hold together."""

    code: str
    message: str
    findings: list[str] = Field(default_factory=list)
    conflict: ConflictSet | None = Field(
        default=None, description="for an infeasible problem: a small set of its constraints that "
        "cannot hold together, by path and in words")


def _uuid_text(value: Any) -> Any:
    """A job id given as a `uuid.UUID` (as the service's store hands it) as its text."""
    return str(value) if isinstance(value, UUID) else value


#: A job's id: a UUID, held and read as its text (``6f1d0c55-1e5c-...``).
JobId = Annotated[str, BeforeValidator(_uuid_text), Field(json_schema_extra={"format": "uuid"})]


class JobPublic(WireModel):
    """A layout job as clients see it."""

    id: JobId
    status: JobStatus
    termination: Termination | None = Field(
        default=None, description="optimal, timelimit, stalled, infeasible, interrupted, "
        "no_solution; set when the job ends")
    progress: Progress | None = None
    error: JobError | None = None
    attempts: int
    time_limit: float = Field(description="the longest the job may run (s): the brief's "
                              "options.time_limit, else its default (twice one floor's "
                              "default, the late allowance for a first layout), at most "
                              "FLOORPLAN_MAX_TIME_LIMIT")
    created_at: datetime
    started_at: datetime | None = None
    finished_at: datetime | None = None


class JobPage(WireModel):
    """One page of ``GET /v1/layouts``, newest job first."""

    data: list[JobPublic]
    next_cursor: str | None = Field(default=None, description="pass as ?cursor= for the next page")


class FieldError(WireModel):
    """One bad field of a request."""

    field: str = Field(description="dotted path to the field, e.g. rooms.2.positions.0")
    loc: list[str | int]
    message: str
    type: str

    def __str__(self) -> str:
        """``field.path: message``."""
        return f"{self.field}: {self.message}"


class Validation(WireModel):
    """What POST /v1/validate finds without solving."""

    valid: bool = Field(description="well formed and no cheap impossibility found")
    errors: list[FieldError] = Field(default_factory=list)
    findings: list[str] = Field(default_factory=list,
                                description="reasons no layout can exist")
    problem: Problem | None = Field(
        default=None, description="the problem as it would be solved, a template expanded: the "
        "fields given or filled in (defaults left out); edit it and send it as is. "
        "Absent when the problem is not well formed")
    feasible: bool | None = Field(
        default=None, description="with explain: true when SCIP found a layout meeting every hard "
        "constraint, false when it proved there is none, null when neither in the time "
        "given; absent without explain")
    conflict: ConflictSet | None = Field(
        default=None, description="with explain, when no layout can exist: a small set of the "
        "problem's constraints that cannot hold together, by path and in words")


#: Bounds at or beyond this magnitude are SCIP's infinity, and shown as such.
SCIP_INFINITY = 1e19


def format_number(value: float) -> str:
    """An objective or bound for people: ``12.41``, ``3.2e+07``, ``inf``."""
    if not math.isfinite(value) or abs(value) >= SCIP_INFINITY:
        return "-inf" if value < 0 else "inf"
    return f"{value:.3g}" if abs(value) >= 1e6 else f"{round(value, 2) + 0.0:.2f}"


# Batches: many layouts of one brief, each its own job (docs/service.md, "Endpoints").

#: Most layouts one batch may ask for.
MAX_BATCH_COUNT = 10_000


class BatchRequest(WireModel):
    """``POST /v1/batches``: one brief laid out `count` times, seeds `seed`, `seed` + 1, ..."""

    problem: dict[str, Any] = Field(description="the brief: a problem, templated or not")
    count: int = Field(ge=1, le=MAX_BATCH_COUNT, description="layouts to make")
    seed: int = Field(0, ge=0, le=2**31 - 1 - MAX_BATCH_COUNT,
                      description="the first layout's seed")
    time_limit: float | None = Field(
        None, gt=0, le=86400, description="seconds per draw of a layout (default: the "
        "brief's options.time_limit, else 0.4 s per room, at least 1 s); a layout that is "
        "not good (valid, covering 99 %) is laid out again under another draw, twice at "
        "most (options.redraws), so its job's limit is three times this")
    vary_program: bool = Field(False, description="draw room counts and sizes from a "
                               "templated brief's template, per seed")
    name: str | None = Field(None, max_length=200, description="default: the brief's name")


class BatchPublic(WireModel):
    """A batch as clients see it: its progress and counts."""

    id: JobId
    name: str
    count: int
    seed: int
    vary_program: bool
    status: JobStatus = Field(description="queued until a layout starts, running until every "
                              "layout ended; then succeeded (every layout), failed (some "
                              "failed) or canceled (some canceled)")
    queued: int
    running: int
    succeeded: int
    failed: int
    canceled: int
    valid: int | None = Field(None, description="with ?summary=true: layouts valid and "
                              "covering 99 % of the floor")
    distinct_plans: int | None = Field(None, description="with ?summary=true: geometrically "
                                       "distinct plans among the finished layouts")
    distinct_graphs: int | None = Field(None, description="with ?summary=true: distinct room "
                                        "adjacency graphs")
    created_at: datetime


class BatchLayoutLine(WireModel):
    """One line of ``GET /v1/batches/{id}/results`` (NDJSON): a finished layout."""

    index: int = Field(description="the layout's place in the batch (seed = batch seed + index)")
    seed: int
    job_id: JobId
    status: JobStatus
    termination: Termination | None = None
    valid: bool | None = None
    coverage: float | None = None
    objective: float | None = Field(None, description="Eq. 12")
    solve_time: float | None = None
    layout: Layout | None = Field(None, description="the layout (left out with "
                                  "?layouts=false)")
    error: JobError | None = None
