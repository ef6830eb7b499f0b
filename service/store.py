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
"""

from __future__ import annotations

import json
import shutil
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sqlalchemy import (
    Engine,
    and_,
    create_engine,
    delete,
    event,
    func,
    insert,
    or_,
    select,
    update,
)
from sqlalchemy.engine import Connection
from sqlalchemy.exc import DBAPIError, IntegrityError

from floorplan.models.jobs import JobStatus
from floorplan.service.migrations import upgrade
from floorplan.service.records import Batch, BatchLayout, Event, Job
from floorplan.service.tables import batches, events, jobs

#: Attempts at appending an event when another writer took its sequence number.
EVENT_RETRIES = 5


class IdempotencyConflict(Exception):
    """The same Idempotency-Key came with another body."""


#: What the database driver raises when the store cannot do what it is asked: a full
#: disk, a read-only file or server, a lost connection. The API answers it with 503.
StoreUnavailable = DBAPIError


class JobStore:
    """Job records and their events."""

    def __init__(self, url: str, *, migrate: bool = True, min_free_bytes: int = 0) -> None:
        self.engine: Engine = create_engine(url, pool_pre_ping=True)
        #: The SQLite file's directory, whose free space `unwritable` watches.
        self.directory: Path | None = None
        self.min_free_bytes = min_free_bytes
        if url.startswith("sqlite"):
            event.listen(self.engine, "connect", _sqlite_pragmas)
            if self.engine.url.database not in (None, "", ":memory:"):
                self.directory = Path(str(self.engine.url.database)).resolve().parent
        if migrate:
            upgrade(self.engine)

    @classmethod
    def sqlite(cls, path: Path) -> JobStore:
        path.parent.mkdir(parents=True, exist_ok=True)
        return cls(f"sqlite:///{path}")

    @contextmanager
    def _tx(self) -> Iterator[Connection]:
        with self.engine.begin() as conn:
            yield conn

    # Creating and reading.

    def create(
        self, *, problem: str, time_limit: float, owner: str = "",
        idempotency_key: str | None = None, body_hash: str | None = None,
    ) -> tuple[Job, bool]:
        """A new queued job, or with a known Idempotency-Key the job it made before
        (the flag says whether it is new). Another body under that key is refused."""
        now = time.time()
        try:
            with self._tx() as conn:
                if idempotency_key is not None:
                    known = self._known(conn, owner, idempotency_key, body_hash)
                    if known is not None:
                        return known, False
                job_id = str(uuid.uuid4())
                conn.execute(insert(jobs).values(
                    id=job_id, owner=owner, status=JobStatus.QUEUED, problem=problem,
                    time_limit=time_limit, idempotency_key=idempotency_key,
                    body_hash=body_hash, attempts=0, cancel_requested=False, created_at=now,
                    updated_at=now,
                ))
                row = conn.execute(select(jobs).where(jobs.c.id == job_id)).one()
        except IntegrityError:
            # A concurrent request with the same key inserted first (the unique index on
            # owner and key): its job is the answer, as for a replay.
            if idempotency_key is None:
                raise
            with self._tx() as conn:
                known = self._known(conn, owner, idempotency_key, body_hash)
            if known is None:
                raise
            return known, False
        return _job(row), True

    # Batches (issue 23).

    def create_batch(
        self, *, owner: str, name: str, seed: int, vary_program: bool,
        problems: list[tuple[str, float]],
    ) -> tuple[Batch, list[Job]]:
        """A batch and its queued jobs (one per (problem JSON, time limit), in order), in
        one transaction: a restart finds the whole batch or none of it."""
        now = time.time()
        batch_id = str(uuid.uuid4())
        ids = [str(uuid.uuid4()) for _ in problems]
        with self._tx() as conn:
            conn.execute(insert(batches).values(
                id=batch_id, owner=owner, name=name, count=len(problems), seed=seed,
                vary_program=vary_program, created_at=now))
            conn.execute(insert(jobs), [
                {"id": job_id, "owner": owner, "status": JobStatus.QUEUED,
                 "problem": problem, "time_limit": time_limit, "attempts": 0,
                 "cancel_requested": False, "created_at": now, "updated_at": now,
                 "batch_id": batch_id, "batch_index": index}
                for index, (job_id, (problem, time_limit)) in enumerate(
                    zip(ids, problems, strict=True))])
            rows = conn.execute(select(jobs).where(jobs.c.batch_id == batch_id)
                                .order_by(jobs.c.batch_index)).all()
        batch = Batch(batch_id, owner, name, len(problems), seed, vary_program, now)
        return batch, [_job(row) for row in rows]

    def get_batch(self, batch_id: str, owner: str | None = None) -> Batch | None:
        query = select(batches).where(batches.c.id == batch_id)
        if owner is not None:
            query = query.where(batches.c.owner == owner)
        with self._tx() as conn:
            row = conn.execute(query).first()
        if row is None:
            return None
        return Batch(row.id, row.owner, row.name, row.count, row.seed, bool(row.vary_program),
                     row.created_at)

    def batch_counts(self, batch_id: str) -> dict[JobStatus, int]:
        """How many of the batch's jobs are in each status."""
        with self._tx() as conn:
            rows = conn.execute(select(jobs.c.status, func.count()).where(
                jobs.c.batch_id == batch_id).group_by(jobs.c.status)).all()
        return {JobStatus(status): int(n) for status, n in rows}

    def batch_layouts(self, batch_id: str, *, after: int, limit: int) -> list[BatchLayout]:
        """The batch's finished jobs with index above `after`, in index order, at most
        `limit`, with their results."""
        query = (select(jobs.c.batch_index, jobs.c.id, jobs.c.status, jobs.c.termination,
                        jobs.c.result, jobs.c.error)
                 .where(jobs.c.batch_id == batch_id, jobs.c.batch_index > after,
                        jobs.c.status.in_([JobStatus.SUCCEEDED, JobStatus.FAILED,
                                           JobStatus.CANCELED]))
                 .order_by(jobs.c.batch_index).limit(limit))
        with self._tx() as conn:
            return [BatchLayout(row.batch_index, row.id, JobStatus(row.status), row.termination,
                                row.result, json.loads(row.error) if row.error else None)
                    for row in conn.execute(query)]

    def batch_plans(self, batch_id: str, *, limit: int) -> list[str]:
        """The layouts (JSON) of the batch's succeeded jobs, the `limit` last finished:
        the plans a new layout of the batch is moved apart from (service.batch)."""
        query = (select(jobs.c.result)
                 .where(jobs.c.batch_id == batch_id, jobs.c.status == JobStatus.SUCCEEDED,
                        jobs.c.result.is_not(None))
                 .order_by(jobs.c.finished_at.desc()).limit(limit))
        with self._tx() as conn:
            return [row.result for row in conn.execute(query)]

    def batch_unfinished(self, batch_id: str) -> list[str]:
        """The ids of the batch's jobs not yet finished."""
        with self._tx() as conn:
            return [row.id for row in conn.execute(select(jobs.c.id).where(
                jobs.c.batch_id == batch_id,
                jobs.c.status.in_([JobStatus.QUEUED, JobStatus.RUNNING])))]

    @staticmethod
    def _known(
        conn: Connection, owner: str, idempotency_key: str, body_hash: str | None
    ) -> Job | None:
        """The job `owner` made with `idempotency_key`, if any; another body under that
        key is refused."""
        row = conn.execute(select(jobs).where(
            jobs.c.owner == owner, jobs.c.idempotency_key == idempotency_key
        )).first()
        if row is None:
            return None
        if row.body_hash != body_hash:
            raise IdempotencyConflict(idempotency_key)
        return _job(row)

    def get(self, job_id: str, owner: str | None = None) -> Job | None:
        query = select(jobs).where(jobs.c.id == job_id)
        if owner is not None:
            query = query.where(jobs.c.owner == owner)
        with self._tx() as conn:
            row = conn.execute(query).first()
        return _job(row) if row is not None else None

    def list(
        self, *, owner: str | None, status: JobStatus | None, limit: int,
        after: tuple[float, str] | None,
    ) -> list[Job]:
        """Newest first; `after` is the (created_at, id) of the last job already seen.
        Without their problem, result and incumbent (empty and None): a page of 200 jobs
        would otherwise load every stored layout (issue 20: 0.37 -> 1.46 GB)."""
        listed = [c for c in jobs.c if c.name not in _HEAVY]
        query = select(*listed).order_by(jobs.c.created_at.desc(), jobs.c.id.desc()).limit(limit)
        if owner is not None:
            query = query.where(jobs.c.owner == owner)
        if status is not None:
            query = query.where(jobs.c.status == status)
        if after is not None:
            created, job_id = after
            query = query.where(or_(jobs.c.created_at < created,
                                    and_(jobs.c.created_at == created, jobs.c.id < job_id)))
        with self._tx() as conn:
            return [_job(row, light=True) for row in conn.execute(query)]

    def count(self, status: JobStatus) -> int:
        with self._tx() as conn:
            return int(conn.execute(
                select(func.count()).select_from(jobs).where(jobs.c.status == status)
            ).scalar_one())

    def active(self, owner: str) -> int:
        """`owner`'s jobs queued or running."""
        with self._tx() as conn:
            return int(conn.execute(select(func.count()).select_from(jobs).where(
                jobs.c.owner == owner,
                jobs.c.status.in_([JobStatus.QUEUED, JobStatus.RUNNING]))).scalar_one())

    # The runner's side.

    def claim_next(self) -> Job | None:
        """The oldest queued job, now running (first in, first out)."""
        with self._tx() as conn:
            row = conn.execute(select(jobs.c.id).where(jobs.c.status == JobStatus.QUEUED)
                               .order_by(jobs.c.created_at, jobs.c.id).limit(1)).first()
            if row is None:
                return None
            now = time.time()
            claimed = conn.execute(update(jobs).where(
                jobs.c.id == row.id, jobs.c.status == JobStatus.QUEUED
            ).values(status=JobStatus.RUNNING, started_at=now, updated_at=now,
                     attempts=jobs.c.attempts + 1))
            if claimed.rowcount != 1:
                return None
            job = _job(conn.execute(select(jobs).where(jobs.c.id == row.id)).one())
        self.add_event(job.id, "status", {"status": JobStatus.RUNNING})
        return job

    def claim(self, job_id: str, worker: str) -> Job | None:
        """Take a queued job for `worker` (the distributed mode): it is then running, and
        its lease starts. None when the job is not queued (another worker holds it, it
        ended, or it was canceled): a duplicate delivery of its task is then a no-op."""
        now = time.time()
        with self._tx() as conn:
            claimed = conn.execute(update(jobs).where(
                jobs.c.id == job_id, jobs.c.status == JobStatus.QUEUED
            ).values(status=JobStatus.RUNNING, started_at=now, updated_at=now,
                     heartbeat_at=now, worker=worker, attempts=jobs.c.attempts + 1))
            if claimed.rowcount != 1:
                return None
            job = _job(conn.execute(select(jobs).where(jobs.c.id == job_id)).one())
        self.add_event(job.id, "status", {"status": JobStatus.RUNNING})
        return job

    def heartbeat(self, job_id: str, worker: str) -> bool | None:
        """Renew `worker`'s lease on a running job. Returns whether a cancel was asked
        for, or None when the job is no longer this worker's to run."""
        with self._tx() as conn:
            renewed = conn.execute(update(jobs).where(
                jobs.c.id == job_id, jobs.c.worker == worker,
                jobs.c.status == JobStatus.RUNNING,
            ).values(heartbeat_at=time.time()))
            if renewed.rowcount != 1:
                return None
            return bool(conn.execute(select(jobs.c.cancel_requested)
                                     .where(jobs.c.id == job_id)).scalar_one())

    def set_progress(
        self, job_id: str, progress: dict[str, Any], *, worker: str | None = None
    ) -> None:
        with self._tx() as conn:
            conn.execute(update(jobs).where(*_held(job_id, worker)).values(
                progress=json.dumps(progress), updated_at=time.time()))

    def set_incumbent(self, job_id: str, layout_json: str, *, worker: str | None = None) -> None:
        with self._tx() as conn:
            conn.execute(update(jobs).where(*_held(job_id, worker)).values(
                incumbent=layout_json, updated_at=time.time()))

    def finish(
        self, job_id: str, status: JobStatus, *, termination: str | None = None,
        result: str | None = None, error: dict[str, Any] | None = None,
        worker: str | None = None,
    ) -> bool:
        """Record the end of a job (idempotent: a finished job stays as it ended). With
        `worker`, only while that worker holds the job. Returns whether it was recorded."""
        now = time.time()
        with self._tx() as conn:
            done = conn.execute(update(jobs).where(
                *_held(job_id, worker),
                jobs.c.status.in_([JobStatus.QUEUED, JobStatus.RUNNING]),
            ).values(status=status, termination=termination, result=result,
                     error=json.dumps(error) if error else None, finished_at=now,
                     updated_at=now))
        if done.rowcount:
            self.add_event(job_id, "status", {"status": status, "termination": termination,
                                              "error": error})
        return bool(done.rowcount)

    def request_cancel(self, job_id: str) -> Job | None:
        """Mark a job for cancelling; a queued one is canceled at once (only while still
        queued: one that a worker claimed meanwhile is stopped by that worker)."""
        now = time.time()
        with self._tx() as conn:
            conn.execute(update(jobs).where(
                jobs.c.id == job_id, jobs.c.status.in_([JobStatus.QUEUED, JobStatus.RUNNING])
            ).values(cancel_requested=True, updated_at=now))
            canceled = conn.execute(update(jobs).where(
                jobs.c.id == job_id, jobs.c.status == JobStatus.QUEUED
            ).values(status=JobStatus.CANCELED, termination="interrupted", finished_at=now,
                     updated_at=now))
        if canceled.rowcount:
            self.add_event(job_id, "status", {"status": JobStatus.CANCELED,
                                              "termination": "interrupted", "error": None})
        return self.get(job_id)

    def delete(self, job_id: str) -> None:
        with self._tx() as conn:
            conn.execute(delete(events).where(events.c.job_id == job_id))
            conn.execute(delete(jobs).where(jobs.c.id == job_id))

    def recover(self, retry_limit: int) -> tuple[int, int]:
        """After a restart: jobs left running go back to the queue, or fail once they
        have been tried `retry_limit` + 1 times. Returns (requeued, failed)."""
        with self._tx() as conn:
            stale = conn.execute(select(jobs.c.id, jobs.c.attempts, jobs.c.cancel_requested)
                                 .where(jobs.c.status == JobStatus.RUNNING)).all()
        requeued = failed = 0
        for row in stale:
            if row.cancel_requested:
                self.finish(row.id, JobStatus.CANCELED, termination="interrupted")
            elif row.attempts > retry_limit:
                failed += 1
                self.finish(row.id, JobStatus.FAILED, error={
                    "code": "retries_exhausted",
                    "message": f"the service stopped during this job {row.attempts} times",
                })
            else:
                requeued += 1
                with self._tx() as conn:
                    conn.execute(update(jobs).where(jobs.c.id == row.id).values(
                        status=JobStatus.QUEUED, updated_at=time.time()))
                self.add_event(row.id, "status", {"status": JobStatus.QUEUED,
                                                  "detail": "requeued after a restart"})
        return requeued, failed

    def hand_back(self, job_id: str, *, worker: str | None = None) -> bool:
        """A running job the service stops gracefully goes back to the queue, and the
        interrupted run does not count as an attempt. Returns whether it went back."""
        with self._tx() as conn:
            back = conn.execute(update(jobs).where(
                *_held(job_id, worker), jobs.c.status == JobStatus.RUNNING
            ).values(status=JobStatus.QUEUED, attempts=jobs.c.attempts - 1, worker=None,
                     dispatched_at=None, updated_at=time.time()))
        if back.rowcount:
            self.add_event(job_id, "status", {"status": JobStatus.QUEUED,
                                              "detail": "handed back by a stopping worker"})
        return bool(back.rowcount)

    # The reconciler's side (the distributed mode).

    def requeue_stale(self, lease_seconds: float, retry_limit: int) -> list[str]:
        """Running jobs whose worker has not renewed its lease for `lease_seconds` (it
        died, or lost the database) go back to the queue, or fail once tried
        `retry_limit` + 1 times, or end canceled when a cancel was asked for. Each row
        changes under a condition, so concurrent reconcilers never both act on one job.
        Returns the ids put back in the queue, to be dispatched again."""
        cutoff = time.time() - lease_seconds
        # No heartbeat at all: a job an embedded runner left running in this store.
        expired = or_(jobs.c.heartbeat_at < cutoff, jobs.c.heartbeat_at.is_(None))
        with self._tx() as conn:
            stale = conn.execute(select(
                jobs.c.id, jobs.c.attempts, jobs.c.cancel_requested, jobs.c.worker,
            ).where(jobs.c.status == JobStatus.RUNNING, expired)).all()
        requeued: list[str] = []
        for row in stale:
            if row.cancel_requested:
                self.finish(row.id, JobStatus.CANCELED, termination="interrupted",
                            worker=row.worker)
            elif row.attempts > retry_limit:
                self.finish(row.id, JobStatus.FAILED, worker=row.worker, error={
                    "code": "retries_exhausted",
                    "message": f"the worker running this job was lost {row.attempts} times",
                })
            else:
                with self._tx() as conn:
                    back = conn.execute(update(jobs).where(
                        jobs.c.id == row.id, jobs.c.status == JobStatus.RUNNING, expired,
                    ).values(status=JobStatus.QUEUED, worker=None, dispatched_at=None,
                             updated_at=time.time()))
                if back.rowcount:
                    requeued.append(row.id)
                    self.add_event(row.id, "status", {
                        "status": JobStatus.QUEUED,
                        "detail": f"requeued: worker {row.worker} stopped answering"})
        return requeued

    def take_undispatched(self, older_than: float) -> list[str]:
        """Queued jobs never handed to the broker (it was down, or the API node died
        between the commit and the send), created before `older_than`, oldest first;
        each is marked dispatched by a conditional update, so that of several
        reconcilers only one sends it."""
        with self._tx() as conn:
            found = [r.id for r in conn.execute(select(jobs.c.id).where(
                jobs.c.status == JobStatus.QUEUED, jobs.c.dispatched_at.is_(None),
                jobs.c.created_at < older_than,
            ).order_by(jobs.c.created_at, jobs.c.id))]
        taken: list[str] = []
        for job_id in found:
            with self._tx() as conn:
                won = conn.execute(update(jobs).where(
                    jobs.c.id == job_id, jobs.c.status == JobStatus.QUEUED,
                    jobs.c.dispatched_at.is_(None),
                ).values(dispatched_at=time.time()))
            if won.rowcount:
                taken.append(job_id)
        return taken

    def queued(self) -> list[str]:
        """Every queued job, oldest first (to send again when the broker lost its queue)."""
        with self._tx() as conn:
            return [r.id for r in conn.execute(select(jobs.c.id).where(
                jobs.c.status == JobStatus.QUEUED).order_by(jobs.c.created_at, jobs.c.id))]

    def mark_dispatched(self, job_id: str, dispatched: bool = True) -> None:
        with self._tx() as conn:
            conn.execute(update(jobs).where(jobs.c.id == job_id).values(
                dispatched_at=time.time() if dispatched else None))

    def purge(self, older_than: float) -> int:
        """Delete finished jobs that ended before `older_than` (epoch seconds)."""
        with self._tx() as conn:
            ids = [r.id for r in conn.execute(select(jobs.c.id).where(
                jobs.c.finished_at.is_not(None), jobs.c.finished_at < older_than))]
            if ids:
                conn.execute(delete(events).where(events.c.job_id.in_(ids)))
                conn.execute(delete(jobs).where(jobs.c.id.in_(ids)))
        return len(ids)

    # Events.

    def add_event(self, job_id: str, kind: str, data: dict[str, Any] | str) -> int:
        """Append an event; its sequence number is the SSE event id."""
        payload = data if isinstance(data, str) else json.dumps(data)
        for attempt in range(EVENT_RETRIES):
            try:
                with self._tx() as conn:
                    last = conn.execute(select(func.max(events.c.seq))
                                        .where(events.c.job_id == job_id)).scalar()
                    seq = (last or 0) + 1
                    conn.execute(insert(events).values(job_id=job_id, seq=seq, kind=kind,
                                                       data=payload, created_at=time.time()))
                return seq
            except IntegrityError:
                # Two writers took the same number (the runner and a cancel): take the next.
                if attempt == EVENT_RETRIES - 1:
                    raise
        raise AssertionError("unreachable")

    def events_after(self, job_id: str, seq: int) -> list[Event]:
        with self._tx() as conn:
            rows = conn.execute(select(events).where(events.c.job_id == job_id,
                                                     events.c.seq > seq)
                                .order_by(events.c.seq)).all()
        return [Event(r.job_id, r.seq, r.kind, r.data) for r in rows]

    def last_event(self, job_id: str) -> int:
        """The sequence number of `job_id`'s newest event (0: none yet)."""
        with self._tx() as conn:
            last = conn.execute(select(func.max(events.c.seq))
                                .where(events.c.job_id == job_id)).scalar()
        return int(last or 0)

    def unwritable(self) -> str | None:
        """Why the store cannot take a job now, or None when it can: a write is refused
        (a read-only file or mount, a read-only PostgreSQL), or the SQLite file's
        directory has less than `min_free_bytes` left (a job accepted there would be
        lost when its solve's writes fail)."""
        if self.directory is not None and self.min_free_bytes:
            try:
                free = shutil.disk_usage(self.directory).free
            except OSError as err:
                return f"its directory is not readable ({err.strerror})"
            if free < self.min_free_bytes:
                return (f"its disk has {free} bytes free, under the {self.min_free_bytes} "
                        "of FLOORPLAN_MIN_FREE_BYTES")
        try:  # a write that changes nothing: refused all the same by a read-only store
            with self._tx() as conn:
                conn.execute(update(jobs).where(jobs.c.id == _PROBE)
                             .values(updated_at=jobs.c.updated_at))
        except DBAPIError as err:
            return f"it refuses writes ({str(err.orig)[:200]})"
        return None

    def ping(self) -> bool:
        with self._tx() as conn:
            return conn.execute(select(1)).scalar() == 1


def _held(job_id: str, worker: str | None) -> list[Any]:
    """The WHERE clause of a write to a job, fenced to `worker` when one is named."""
    clause = [jobs.c.id == job_id]
    if worker is not None:
        clause.append(jobs.c.worker == worker)
    return clause


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA synchronous=NORMAL")  # WAL keeps it durable across crashes
    cursor.execute("PRAGMA busy_timeout=5000")
    cursor.close()


#: No job has this id: `unwritable` writes to it, which changes nothing.
_PROBE = "-"
#: The columns a listing leaves out: the documents, megabytes each for a large floor.
_HEAVY = frozenset({"problem", "result", "incumbent"})


def _job(row: Any, *, light: bool = False) -> Job:
    """A row as a job; `light`: a row without the `_HEAVY` columns."""
    return Job(
        id=row.id, owner=row.owner, status=JobStatus(row.status), termination=row.termination,
        problem="" if light else row.problem, time_limit=row.time_limit,
        result=None if light else row.result, incumbent=None if light else row.incumbent,
        progress=json.loads(row.progress) if row.progress else None,
        error=json.loads(row.error) if row.error else None,
        idempotency_key=row.idempotency_key, body_hash=row.body_hash, attempts=row.attempts,
        cancel_requested=bool(row.cancel_requested), created_at=row.created_at,
        started_at=row.started_at, finished_at=row.finished_at, updated_at=row.updated_at,
        worker=row.worker, heartbeat_at=row.heartbeat_at, batch_id=row.batch_id,
    )
