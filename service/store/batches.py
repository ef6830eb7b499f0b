"""Batches: a batch and its queued jobs made in one transaction, and what its jobs add
up to (counts by status, finished layouts in order, the plans a new layout is moved
apart from)."""

from __future__ import annotations

import json
import time
import uuid

from sqlalchemy import func, insert, select

from floorplan.models.jobs import JobStatus
from floorplan.service.records import Batch, BatchLayout, Job
from floorplan.service.store.base import Quota, StoreBase
from floorplan.service.store.jobs import job_of_row
from floorplan.service.tables import batches, jobs


class BatchRecords(StoreBase):
    """Batches of jobs."""

    def create_batch(
        self, *, owner: str, name: str, seed: int, vary_program: bool, brief: str,
        count: int, time_limit: float | None, time_ceiling: float, job_time_limit: float,
        quota: Quota | None = None,
    ) -> tuple[Batch, list[Job]]:
        """A batch and its `count` queued jobs, in one transaction: a restart finds the
        whole batch or none of it. The brief (JSON as sent) is stored once, in the
        batch's row; each job's problem is derived from it when the job is read
        (`_job`), `job_time_limit` standing for the jobs' limits until then. Within
        `quota`, counted in that transaction (QuotaExceeded)."""
        now = time.time()
        batch_id = str(uuid.uuid4())
        with self._admission() as conn:
            if quota is not None:
                self._within(conn, owner, count, quota, len(brief.encode()))
            conn.execute(insert(batches).values(
                id=batch_id, owner=owner, name=name, count=count, seed=seed,
                vary_program=vary_program, created_at=now, brief=brief,
                time_limit=time_limit, time_ceiling=time_ceiling))
            conn.execute(insert(jobs), [
                {"id": str(uuid.uuid4()), "owner": owner, "status": JobStatus.QUEUED,
                 "problem": None, "time_limit": job_time_limit, "attempts": 0,
                 "cancel_requested": False, "created_at": now, "updated_at": now,
                 "batch_id": batch_id, "batch_index": index}
                for index in range(count)])
            rows = conn.execute(select(jobs).where(jobs.c.batch_id == batch_id)
                                .order_by(jobs.c.batch_index)).all()
        batch = Batch(batch_id, owner, name, count, seed, vary_program, now)
        return batch, [job_of_row(row, light=True) for row in rows]

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
