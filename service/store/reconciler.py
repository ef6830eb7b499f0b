"""The reconciler's side of the store (the distributed mode): running jobs whose
worker's lease ran out, queued jobs never handed to the broker, and finished jobs past
their retention."""

from __future__ import annotations

import time

from sqlalchemy import delete, or_, select, update

from floorplan.models.jobs import JobStatus
from floorplan.service.store.jobs import JobRecords, delete_empty_batches
from floorplan.service.tables import events, jobs


class Reconciling(JobRecords):
    """What the reconciler finds left behind, and the purge of old jobs."""

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
                delete_empty_batches(conn)
        return len(ids)
