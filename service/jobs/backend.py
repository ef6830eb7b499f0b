"""The job-backend interface: what the HTTP API needs of whatever runs the jobs.

The API only talks to a `JobBackend`: it reads and writes job records through its
`store`, tells it about new jobs and cancels, and waits on it for a job's next events.
The implementations are service/jobs/embedded.py and service/jobs/celery/backend.py;
service/jobs/factory.py picks one. This module imports neither.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

from floorplan.service.records import Job
from floorplan.service.store import JobStore


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
