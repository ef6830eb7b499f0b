"""What the service answers, as typed models: jobs, their progress and events, validation
verdicts and problem documents. Problems and layouts are the project's own `models`;
jobs, their progress, errors and validation verdicts are `models.jobs`, the very
definitions the service answers with (`JobInfo` is `models.jobs.JobPublic`, `ErrorInfo`
is `models.jobs.JobError`).

Unknown fields are ignored, so a newer service does not break an older client."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import ConfigDict, Field

from floorplan_client.models import Layout, Problem, Termination
from floorplan_client.models.jobs import (
    BatchLayoutLine,
    BatchPublic,
    FieldError,
    JobError,
    JobPage,
    JobPublic,
    JobStatus,
    Progress,
    Validation,
    WireModel,
    format_number,
)

__all__ = [
    "BatchInfo",
    "BatchLine",
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

#: A layout job as the service reports it (the service's `JobPublic`).
JobInfo = JobPublic
#: Why a job failed (the service's `JobError`).
ErrorInfo = JobError
#: A batch of layouts as the service reports it (the service's `BatchPublic`).
BatchInfo = BatchPublic
#: One finished layout of a batch, a line of its results (the service's `BatchLayoutLine`).
BatchLine = BatchLayoutLine


class ProblemDocument(WireModel):
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


# Events of a job, from its event stream (or made from polling where there is none).


class StatusEvent(WireModel):
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


class ProgressEvent(WireModel):
    """The solve moved on: a phase, a level, a sub-domain, a bound."""

    kind: Literal["progress"] = "progress"
    id: int | None = None
    progress: Progress

    def __str__(self) -> str:
        """E.g. ``progress level 1  objective 12.41  elapsed 0.52 s  level 1: optimal``."""
        return f"progress {self.progress}"


class IncumbentEvent(WireModel):
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
