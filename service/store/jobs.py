"""Job records: creating and reading them (with Idempotency-Keys), the runner's side
(claims, leases, progress, the end, cancels, recovery after a restart), and the fenced
writes of a worker that holds a job."""

from __future__ import annotations

import json
import logging
import time
import uuid
from dataclasses import replace
from typing import Any

from sqlalchemy import and_, delete, exists, func, insert, or_, select, update
from sqlalchemy.engine import Connection
from sqlalchemy.exc import IntegrityError

from floorplan.models.jobs import JobStatus
from floorplan.service.records import Job
from floorplan.service.store.base import Quota
from floorplan.service.store.events import EventLog
from floorplan.service.tables import batches, events, jobs

log = logging.getLogger("floorplan.store")


#: Claims of the fairest job a worker loses to other workers before it claims the job
#: its message names (`claim_fair`); each loss is another worker's claim.
FAIR_TRIES = 100


class IdempotencyConflict(Exception):
    """The same Idempotency-Key came with another body."""


class JobRecords(EventLog):
    """Jobs: created, read, claimed, renewed, ended; each change an event too."""

    # Creating and reading.

    def create(
        self, *, problem: str, time_limit: float, owner: str = "",
        idempotency_key: str | None = None, body_hash: str | None = None,
        quota: Quota | None = None,
    ) -> tuple[Job, bool]:
        """A new queued job, or with a known Idempotency-Key the job it made before
        (the flag says whether it is new). Another body under that key is refused. A new
        job is admitted within `quota`, counted in the inserting transaction
        (QuotaExceeded); a replay is answered whatever the counts."""
        now = time.time()
        try:
            with self._admission() as conn:
                if idempotency_key is not None:
                    known = self._known(conn, owner, idempotency_key, body_hash)
                    if known is not None:
                        return known, False
                if quota is not None:
                    self._within(conn, owner, 1, quota, len(problem.encode()))
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
        return job_of_row(row), True

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
        return job_of_row(row)

    def get(self, job_id: str, owner: str | None = None, *,
            problem: bool = True) -> Job | None:
        """The job; with `problem` False, a layout of a batch comes without its problem
        (empty: `with_problem` derives it), which the routes that only show a job's
        state do not need."""
        query = select(jobs).where(jobs.c.id == job_id)
        if owner is not None:
            query = query.where(jobs.c.owner == owner)
        with self._tx() as conn:
            row = conn.execute(query).first()
        if row is None:
            return None
        return self._job(row) if problem else job_of_row(row)

    def with_problem(self, job: Job) -> Job:
        """`job` with its problem: as it is, or a layout of a batch read without it
        (`get(problem=False)`) read again with it."""
        if job.problem or job.batch_id is None:
            return job
        return self.get(job.id) or job

    def list(
        self, *, owner: str | None, status: JobStatus | None, limit: int,
        after: tuple[float, str] | None,
    ) -> list[Job]:
        """Newest first; `after` is the (created_at, id) of the last job already seen.
        Without their problem, result and incumbent (empty and None): a page of 200 jobs
        would otherwise load every stored layout."""
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
            return [job_of_row(row, light=True) for row in conn.execute(query)]

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
        """The next queued job, now running, fair across owners (`_fairest`)."""
        with self._tx() as conn:
            job_id = self._fairest(conn)
            if job_id is None:
                return None
            now = time.time()
            claimed = conn.execute(update(jobs).where(
                jobs.c.id == job_id, jobs.c.status == JobStatus.QUEUED
            ).values(status=JobStatus.RUNNING, started_at=now, updated_at=now,
                     attempts=jobs.c.attempts + 1))
            if claimed.rowcount != 1:
                return None
            row = conn.execute(select(jobs).where(jobs.c.id == job_id)).one()
        job = self._claimed(row)  # its problem derived after the write lock is released
        self.add_event(job.id, "status", {"status": JobStatus.RUNNING})
        return job

    def claim_fair(self, named: str, worker: str) -> Job | None:
        """Take the next queued job for `worker`, fair across owners (`_fairest`), as
        `claim` takes one: the distributed mode's workers read a broker message
        (`named`) as "a job is waiting", not as which one. Every accepted job sends one
        message and every message claims one job while any is queued, so no job is left
        without a message to claim it. The job is picked and claimed in one transaction,
        its row locked (PostgreSQL: rows other workers are claiming are skipped); a job
        another worker claimed first is looked for again, and since each such loss is
        another worker's claim, the looking ends. After `FAIR_TRIES` losses, or when every
        queued row is locked, the job the message names. None when nothing is queued."""
        for _ in range(FAIR_TRIES):
            now = time.time()
            with self._tx() as conn:
                job_id = self._fairest(conn)
                if job_id is None:
                    # Nothing unlocked is queued; the named job may still be, its row held
                    # for a moment by another writer (the API marks a job dispatched just
                    # after sending its message). Claiming it waits for that lock: skipping
                    # it dropped the message and left the job queued for good.
                    break
                claimed = conn.execute(update(jobs).where(
                    jobs.c.id == job_id, jobs.c.status == JobStatus.QUEUED
                ).values(status=JobStatus.RUNNING, started_at=now, updated_at=now,
                         heartbeat_at=now, worker=worker, attempts=jobs.c.attempts + 1))
                row = (conn.execute(select(jobs).where(jobs.c.id == job_id)).one()
                       if claimed.rowcount == 1 else None)
            if row is not None:
                job = self._claimed(row)
                self.add_event(job.id, "status", {"status": JobStatus.RUNNING})
                return job
        return self.claim(named, worker)

    @staticmethod
    def _fairest(conn: Connection) -> str | None:
        """The queued job to run next, fair across owners (docs/security.md, "Fair
        scheduling"): the owner with the fewest jobs running, among those the one served
        longest ago (one never served first), and that owner's oldest queued job. First
        in, first out across keys let one key's batch of hundreds hold every solve while
        another key's single job waited behind it. The row is locked for the caller's
        transaction; on PostgreSQL rows locked by another claim are passed over (that
        owner's next job, or the next owner's)."""
        waiting = [row.owner for row in conn.execute(select(jobs.c.owner).distinct().where(
            jobs.c.status == JobStatus.QUEUED))]
        running = {o: int(n) for o, n in conn.execute(select(jobs.c.owner, func.count()).where(
            jobs.c.status == JobStatus.RUNNING, jobs.c.owner.in_(waiting)
        ).group_by(jobs.c.owner))} if waiting else {}
        served = {o: float(t) for o, t in conn.execute(
            select(jobs.c.owner, func.max(jobs.c.started_at)).where(
                jobs.c.owner.in_(waiting), jobs.c.started_at.is_not(None)
            ).group_by(jobs.c.owner))} if waiting else {}
        for owner in sorted(waiting, key=lambda o: (running.get(o, 0), served.get(o) or 0.0, o)):
            row = conn.execute(select(jobs.c.id).where(
                jobs.c.status == JobStatus.QUEUED, jobs.c.owner == owner
            ).order_by(jobs.c.created_at, jobs.c.id).limit(1)
                .with_for_update(skip_locked=True)).first()
            if row is not None:
                return str(row.id)
        return None

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
            row = conn.execute(select(jobs).where(jobs.c.id == job_id)).one()
        job = self._claimed(row)
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
        """Delete a job and its events; a batch whose last job this was goes too (its
        brief is stored once, in its row)."""
        with self._tx() as conn:
            conn.execute(delete(events).where(events.c.job_id == job_id))
            conn.execute(delete(jobs).where(jobs.c.id == job_id))
            delete_empty_batches(conn)

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


    def _claimed(self, row: Any) -> Job:
        """A job just claimed, with its problem; a batch's layout whose derived time
        limit is not the one its row held until then (with `vary_program` each layout's
        programme, and so its default limit, is its own) has its row say so."""
        job = self._job(row)
        if job.time_limit != row.time_limit:
            with self._tx() as conn:
                conn.execute(update(jobs).where(jobs.c.id == job.id).values(
                    time_limit=job.time_limit))
        return job

    def _job(self, row: Any) -> Job:
        """A full row as a job: a layout of a batch stores no problem (NULL), its
        problem is derived from the batch's brief, stored once (`layout_problem`), with
        its own time limit. A brief that cannot give one (it always can: it was checked
        when the batch was made) leaves the problem empty, and the job's solve fails."""
        job = job_of_row(row)
        if row.problem is not None or row.batch_id is None:
            return job
        from floorplan.service.batch import layout_problem

        with self._tx() as conn:
            batch = conn.execute(select(
                batches.c.brief, batches.c.seed, batches.c.time_limit,
                batches.c.vary_program, batches.c.time_ceiling,
            ).where(batches.c.id == row.batch_id)).first()
        if batch is None or batch.brief is None:
            return job
        try:
            problem, time_limit = layout_problem(
                batch.brief, batch.seed + row.batch_index, batch.time_limit,
                bool(batch.vary_program), batch.time_ceiling)
        except Exception:
            log.exception("the problem of job %s could not be derived from its batch's brief",
                          row.id)
            return job
        return replace(job, problem=problem, time_limit=time_limit)


def delete_empty_batches(conn: Connection) -> None:
    """Delete the batches none of whose jobs is left (their briefs with them)."""
    conn.execute(delete(batches).where(~exists().where(jobs.c.batch_id == batches.c.id)))


def _held(job_id: str, worker: str | None) -> list[Any]:
    """The WHERE clause of a write to a job, fenced to `worker` when one is named."""
    clause = [jobs.c.id == job_id]
    if worker is not None:
        clause.append(jobs.c.worker == worker)
    return clause


#: The columns a listing leaves out: the documents, megabytes each for a large floor.
_HEAVY = frozenset({"problem", "result", "incumbent"})


def job_of_row(row: Any, *, light: bool = False) -> Job:
    """A row as a job; `light`: a row without the `_HEAVY` columns."""
    return Job(
        id=row.id, owner=row.owner, status=JobStatus(row.status), termination=row.termination,
        problem="" if light or row.problem is None else row.problem,
        time_limit=row.time_limit,
        result=None if light else row.result, incumbent=None if light else row.incumbent,
        progress=json.loads(row.progress) if row.progress else None,
        error=json.loads(row.error) if row.error else None,
        idempotency_key=row.idempotency_key, body_hash=row.body_hash, attempts=row.attempts,
        cancel_requested=bool(row.cancel_requested), created_at=row.created_at,
        started_at=row.started_at, finished_at=row.finished_at, updated_at=row.updated_at,
        worker=row.worker, heartbeat_at=row.heartbeat_at, batch_id=row.batch_id,
    )
