"""What the service answers, as typed models: jobs, their progress and events, validation
verdicts and problem documents. Problems and layouts are the project's own `models`.

Unknown fields are ignored, so a newer service does not break an older client."""

from __future__ import annotations

import math
from datetime import datetime
from enum import StrEnum
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

try:
    from models import ConflictSet, Layout, Problem, Termination
except ImportError as err:  # pragma: no cover - depends on how it was installed
    raise ImportError(
        "floorplan_client needs the floorplan project's `models` package. Install the "
        "repository's root project with the client, from the repository root: "
        "pip install . ./clients/python (the `floorplan` on PyPI is another project)"
    ) from err

__all__ = [
    "ErrorInfo",
    "Event",
    "FieldError",
    "IncumbentEvent",
    "JobInfo",
    "JobPage",
    "JobStatus",
    "Layout",
    "Problem",
    "ProblemDocument",
    "Progress",
    "ProgressEvent",
    "StatusEvent",
    "Termination",
    "Validation",
]


class JobStatus(StrEnum):
    """Where a job is in its life."""

    QUEUED = "queued"
    """Accepted and waiting for a free solver."""
    RUNNING = "running"
    """Being solved; `JobInfo.progress` and the incumbent layout follow it."""
    SUCCEEDED = "succeeded"
    """Ended with a layout (check `report.valid` and `report.termination`)."""
    FAILED = "failed"
    """Ended without a layout: infeasible, nothing found in time, or the solver died;
    `JobInfo.error` says which."""
    CANCELED = "canceled"
    """Stopped on request; the best layout found by then, if any, is the result."""

    @property
    def terminal(self) -> bool:
        """True once the job has ended and will not change again."""
        return self in (JobStatus.SUCCEEDED, JobStatus.FAILED, JobStatus.CANCELED)


class _Model(BaseModel):
    model_config = ConfigDict(extra="ignore", frozen=True)


class Progress(_Model):
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


class ErrorInfo(_Model):
    """Why a job failed: a code (``infeasible``, ``no_solution``, ``worker_died``,
    ``solver_error``, ``retries_exhausted``, ...), a message and, for an infeasible
    problem, the impossibilities found and the constraints that cannot hold together."""

    code: str
    message: str
    findings: list[str] = Field(default_factory=list)
    conflict: ConflictSet | None = Field(
        default=None, description="a small set of the problem's constraints that cannot "
        "hold together, by path and in words (`models.ConflictSet`)")


class JobInfo(_Model):
    """A layout job as the service reports it."""

    id: str
    status: JobStatus
    termination: Termination | None = Field(
        default=None, description="why the solve stopped; set when the job ends")
    progress: Progress | None = None
    error: ErrorInfo | None = None
    attempts: int = 0
    time_limit: float
    created_at: datetime
    started_at: datetime | None = None
    finished_at: datetime | None = None


class JobPage(_Model):
    """One page of `GET /v1/layouts`."""

    data: list[JobInfo]
    next_cursor: str | None = None


class FieldError(_Model):
    """One bad field of a problem, named by its dotted path (``rooms.2.positions.0``)."""

    field: str
    loc: list[str | int] = Field(default_factory=list)
    message: str
    type: str = ""

    def __str__(self) -> str:
        """``field.path: message``."""
        return f"{self.field}: {self.message}"


class ProblemDocument(_Model):
    """An RFC 9457 problem document: what the service says went wrong.

    The client makes one too where the service sent none (a proxy's HTML error page)
    and for a failed job (`type` then names the job's error code)."""

    model_config = ConfigDict(extra="allow", frozen=True)

    type: str = "about:blank"
    title: str = ""
    status: int | None = None
    detail: str = ""
    instance: str | None = None
    errors: list[FieldError] | None = None

    @property
    def kind(self) -> str:
        """The last segment of `type`, e.g. ``job-not-found``; "" for ``about:blank``."""
        return "" if self.type == "about:blank" else self.type.rstrip("/").rsplit("/", 1)[-1]


class Validation(_Model):
    """What the service finds in a problem without solving it."""

    valid: bool = Field(description="well formed and no cheap impossibility found")
    errors: list[FieldError] = Field(default_factory=list)
    findings: list[str] = Field(default_factory=list,
                                description="reasons no layout can exist")
    problem: Problem | None = Field(
        None, description="the problem as the service would solve it (a template "
        "expanded); None when it is not well formed, or from an older service")
    feasible: bool | None = Field(
        default=None, description="asked with explain: SCIP found a layout (True), proved "
        "there is none (False), or neither in the time given (None)")
    conflict: ConflictSet | None = Field(
        default=None, description="asked with explain, when no layout can exist: the "
        "constraints that cannot hold together")


# Events of a job, from its event stream (or made from polling where there is none).


class StatusEvent(_Model):
    """The job changed status; the last event of a job is its terminal status."""

    kind: Literal["status"] = "status"
    id: int | None = Field(default=None,
                           description="the event's id in the stream (None when polled)")
    status: JobStatus
    termination: Termination | None = None
    error: ErrorInfo | None = None

    def __str__(self) -> str:
        """E.g. ``status succeeded (optimal)`` or ``status failed (infeasible): reason``."""
        text = f"status {self.status.value}"
        if self.termination is not None:
            text += f" ({self.termination.value})"
        if self.error is not None:
            text += f": {self.error.message}"
        return text


class ProgressEvent(_Model):
    """The solve moved on: a phase, a level, a sub-domain, a bound."""

    kind: Literal["progress"] = "progress"
    id: int | None = None
    progress: Progress

    def __str__(self) -> str:
        """E.g. ``progress level 1  objective 12.41  elapsed 0.52 s  level 1: optimal``."""
        return f"progress {self.progress}"


class IncumbentEvent(_Model):
    """A better layout was found; `layout` is it, unchecked
    (``report.termination`` is ``in_progress``)."""

    kind: Literal["incumbent"] = "incumbent"
    id: int | None = None
    progress: Progress = Field(default_factory=lambda: Progress())
    layout: Layout

    def __str__(self) -> str:
        """E.g. ``incumbent objective 12.41, 5 rooms``."""
        objective = self.progress.objective
        if objective is None:
            objective = self.layout.report.objective
        value = format_number(objective) if objective is not None else "?"
        return f"incumbent objective {value}, {len(self.layout.all_rooms)} rooms"


#: One event of a job: tell them apart by `kind` (or isinstance).
Event = Annotated[StatusEvent | ProgressEvent | IncumbentEvent, Field(discriminator="kind")]


#: Bounds at or beyond this magnitude are SCIP's infinity, and shown as such.
SCIP_INFINITY = 1e19


def format_number(value: float) -> str:
    """An objective or bound for people: ``12.41``, ``3.2e+07``, ``inf``."""
    if not math.isfinite(value) or abs(value) >= SCIP_INFINITY:
        return "-inf" if value < 0 else "inf"
    return f"{value:.3g}" if abs(value) >= 1e6 else f"{round(value, 2) + 0.0:.2f}"


def event_from(kind: str, event_id: int | None, data: dict[str, Any]) -> Event | None:
    """The typed event of a stream's ``event:`` kind and JSON ``data:``; None for a kind
    this client does not know (a newer service may send more)."""
    if kind == "status":
        return StatusEvent(id=event_id, **data)
    if kind == "progress":
        return ProgressEvent(id=event_id, progress=Progress(**data))
    if kind == "incumbent":
        return IncumbentEvent(id=event_id, progress=Progress(**(data.get("progress") or {})),
                              layout=Layout.model_validate(data["layout"]))
    return None
