"""The response bodies of the API are the contract's job types (`models.jobs`, shared with
the Python client); this module fills them from the store's records."""

from __future__ import annotations

from datetime import UTC, datetime

from floorplan.models.jobs import JobError, JobPage, JobPublic, Progress, Validation
from floorplan.service.records import Job

__all__ = ["JobPage", "JobPublic", "Validation", "job_public"]


def job_public(job: Job) -> JobPublic:
    """A stored job as clients see it."""
    return JobPublic(
        id=job.id, status=job.status, termination=job.termination,
        progress=Progress(**job.progress) if job.progress else None,
        error=JobError(**job.error) if job.error else None, attempts=job.attempts,
        time_limit=job.time_limit, created_at=_time(job.created_at),
        started_at=_time(job.started_at), finished_at=_time(job.finished_at),
    )


def _time(epoch: float | None) -> datetime | None:
    return datetime.fromtimestamp(epoch, UTC) if epoch is not None else None
