"""Durable job records: SQLAlchemy Core over SQLite in WAL mode (the embedded default)
or PostgreSQL (the distributed mode), one schema for both, kept by Alembic migrations.

A job answered with 202 is a row before the answer leaves; everything a runner or a
worker learns (status, progress, incumbents, the result) is written here, and the event
stream reads it back, so a restart loses nothing but the work in flight. The records
it hands out (`Job`, `Event`, `JobStatus`) are service/records.py's.

In the distributed mode several workers write here: a job is claimed by one worker at
a time (`claim`), which renews its lease (`heartbeat`) while it solves; every write of
a claimed job names that worker, so a worker that lost its lease can no longer touch
the job. The reconciler (`requeue_stale`, `undispatched`) finds what was left behind.

The parts: `base` (the engine, transactions, `unwritable`), `events` (each job's
events), `jobs` (creating, reading, claiming and ending jobs), `reconciler` (what the
reconciler finds left behind), `batches` (batches of jobs); `JobStore` is all of them.
"""

from __future__ import annotations

from floorplan.service.store.base import Quota, QuotaExceeded, StoreUnavailable
from floorplan.service.store.batches import BatchRecords
from floorplan.service.store.events import EVENT_RETRIES
from floorplan.service.store.jobs import IdempotencyConflict
from floorplan.service.store.reconciler import Reconciling

__all__ = ["EVENT_RETRIES", "IdempotencyConflict", "JobStore", "Quota", "QuotaExceeded",
           "StoreUnavailable"]


class JobStore(Reconciling, BatchRecords):
    """Job records, their events, and batches."""
