"""The embedded backend: jobs solved in child processes of the API's own process (the
default, no other server needed)."""

from __future__ import annotations

import asyncio
from typing import Any

from floorplan.models.jobs import JobStatus
from floorplan.service.jobs.backend import JobBackend
from floorplan.service.jobs.processes import Runner
from floorplan.service.records import Job
from floorplan.service.settings import Settings
from floorplan.service.store import JobStore

#: Seconds between two looks at the store for a job's new events (embedded mode).
EMBEDDED_EVENT_POLL = 0.25


class EmbeddedBackend(JobBackend):
    """Solves in spawned child processes of this process (service/jobs/processes.py)."""

    name = "embedded"

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.store = JobStore(settings.store_url, min_free_bytes=settings.min_free_bytes)
        self.runner = Runner(self.store, settings)

    def start(self) -> None:
        self.runner.start()

    def stop(self) -> None:
        self.runner.stop()

    def submitted(self, job: Job) -> None:
        self.runner.notify()

    def cancel(self, job_id: str) -> None:
        self.runner.cancel(job_id)

    def health(self) -> dict[str, Any]:
        unwritable = self.store.unwritable()
        ready = self.store.ping() and self.runner.alive and unwritable is None
        return {"ready": ready, "store": unwritable or "ok", "running": self.runner.running,
                "queued": self.store.count(JobStatus.QUEUED)}

    async def wait_for_events(self, job_id: str, timeout: float) -> None:
        await asyncio.sleep(min(timeout, EMBEDDED_EVENT_POLL))
