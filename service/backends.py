"""One job-backend interface, two implementations: where accepted jobs go to be solved.

The HTTP API only talks to a `JobBackend`: it reads and writes job records through its
`store`, tells it about new jobs and cancels, and waits on it for a job's next events.
`EmbeddedBackend` solves in child processes of the API's own process (the default, no
other server); `CeleryBackend` (service/distributed.py) hands jobs to Celery workers on
other processes or machines through Redis, with the records in PostgreSQL.
"""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from typing import Any

from service.runner import Runner
from service.settings import Settings
from service.store import Job, JobStatus, JobStore

#: Seconds between two looks at the store for a job's new events (embedded mode).
EMBEDDED_EVENT_POLL = 0.25


class JobBackend(ABC):
    """What the API needs of whatever runs the jobs."""

    name: str
    store: JobStore

    @abstractmethod
    def start(self) -> None:
        """Begin dispatching (called once, when the API starts)."""

    @abstractmethod
    def stop(self) -> None:
        """Stop dispatching; jobs this process was running go back to the queue."""

    @abstractmethod
    def submitted(self, job: Job) -> None:
        """A new job is in the store: get it solved. It must not raise for a job already
        committed: the job is accepted, and anything not sent now is sent later."""

    @abstractmethod
    def cancel(self, job_id: str) -> None:
        """Stop a job gracefully wherever it runs; its incumbent becomes the result."""

    @abstractmethod
    def health(self) -> dict[str, Any]:
        """`ready` (bool) and figures for /readyz."""

    @abstractmethod
    async def wait_for_events(self, job_id: str, timeout: float) -> None:
        """Return when `job_id` may have new events, or after at most `timeout` s."""

    async def aclose(self) -> None:
        """Release what `wait_for_events` holds (called on the API's event loop)."""
        return None


class EmbeddedBackend(JobBackend):
    """Solves in spawned child processes of this process (service/runner.py)."""

    name = "embedded"

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.store = JobStore(settings.store_url)
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
        ready = self.store.ping() and self.runner.alive
        return {"ready": ready, "running": self.runner.running,
                "queued": self.store.count(JobStatus.QUEUED)}

    async def wait_for_events(self, job_id: str, timeout: float) -> None:
        await asyncio.sleep(min(timeout, EMBEDDED_EVENT_POLL))


def make_backend(settings: Settings) -> JobBackend:
    """The backend FLOORPLAN_BACKEND names."""
    if settings.backend == "celery":
        from service.distributed import CeleryBackend  # needs the `distributed` extra

        return CeleryBackend(settings)
    return EmbeddedBackend(settings)
