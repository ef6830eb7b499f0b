"""A job as the store hands it out: its status, its record and its events, plain values
that the API, the runners and the workers pass around (service/store/ reads and
writes them)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from floorplan.models.jobs import JobStatus


@dataclass(frozen=True)
class Job:
    id: str
    owner: str
    status: JobStatus
    termination: str | None
    problem: str
    time_limit: float
    result: str | None
    incumbent: str | None
    progress: dict[str, Any] | None
    error: dict[str, Any] | None
    idempotency_key: str | None
    body_hash: str | None
    attempts: int
    cancel_requested: bool
    created_at: float
    started_at: float | None
    finished_at: float | None
    updated_at: float
    worker: str | None = None
    heartbeat_at: float | None = None
    #: The batch the job is a layout of, if any.
    batch_id: str | None = None


@dataclass(frozen=True)
class Event:
    job_id: str
    seq: int
    kind: str
    data: str



@dataclass(frozen=True)
class Batch:
    """A batch of layouts: its jobs name it in their `batch_id`."""

    id: str
    owner: str
    name: str
    count: int
    seed: int
    vary_program: bool
    created_at: float


@dataclass(frozen=True)
class BatchLayout:
    """One finished layout of a batch: its place, its job and the job's outcome."""

    index: int
    job_id: str
    status: JobStatus
    termination: str | None
    result: str | None
    error: dict[str, Any] | None
