"""The response bodies (wire types) of the API: a job as clients see it, a page of jobs,
what validation finds."""

from __future__ import annotations

from datetime import UTC, datetime
from uuid import UUID

from pydantic import BaseModel, Field

from models import ConflictSet
from models import Problem as LayoutProblem
from service.api.errors import FieldError
from service.records import Job, JobStatus


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
