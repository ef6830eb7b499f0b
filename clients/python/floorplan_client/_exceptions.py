"""The exceptions of the client. Every one is a `FloorplanError`:

    FloorplanError
    ├── ProblemFileError (also ValueError)   a problem file cannot be read or is not JSON
    ├── APIConnectionError                   no answer: refused, reset, DNS, ... (.request)
    │   └── APITimeoutError                  no answer in time
    ├── APIStatusError                       an answer of 4xx or 5xx (.status_code, .problem)
    │   ├── BadRequest                   400 a body that is not JSON, a foreign cursor
    │   ├── Unauthorized                 401 no API key, or an unknown one
    │   ├── NotFound                     404 an unknown job (or another key's)
    │   │   └── NoResultYet              404 a job without a layout yet
    │   ├── Conflict                     409 an Idempotency-Key reused with another body;
    │   │                                    deleting a job still running
    │   ├── PayloadTooLarge              413 a problem over the service's size limit
    │   ├── InvalidProblem               422 a problem the service refuses (.errors)
    │   ├── RateLimited                  429 the queue is full (.retry_after)
    │   └── ServerError                  5xx the service (or a proxy) failed
    ├── JobFailed                        `Job.wait`: the job ended without a layout (.job)
    │   └── Infeasible                       ... because no layout can exist (.findings, .conflict)
    ├── JobCanceled                      `Job.wait`: the job was canceled (.job)
    └── WaitTimeout (also TimeoutError)  `Job.wait` or `Job.events` ran out of time (.job)

Each error about something the service said carries its RFC 9457 problem document as
`problem` (for a failed job the client makes one from the job's error).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import httpx2 as httpx

if TYPE_CHECKING:
    from floorplan_client.models import ConflictSet
    from floorplan_client.types import FieldError, JobInfo, ProblemDocument


class FloorplanError(Exception):
    """Every error raised by this client."""


class ProblemFileError(FloorplanError, ValueError):
    """A problem given as a path that cannot be read, or that is not JSON."""


class APIConnectionError(FloorplanError):
    """The request got no answer (after the retries): the service is down or unreachable,
    or the connection broke."""

    def __init__(self, message: str, *, request: httpx.Request) -> None:
        super().__init__(message)
        self.request = request


class APITimeoutError(APIConnectionError):
    """The request got no answer within its timeout (after the retries)."""


class APIStatusError(FloorplanError):
    """The service answered with a 4xx or 5xx status; `problem` says why."""

    def __init__(self, problem: ProblemDocument, *, response: httpx.Response) -> None:
        super().__init__(_describe(problem, response.status_code))
        self.problem = problem
        self.response = response
        self.status_code = response.status_code

    @property
    def request(self) -> httpx.Request:
        """The request that got this answer."""
        return self.response.request


class BadRequest(APIStatusError):
    """400: a body that is not JSON, or a list cursor the service did not give out."""


class Unauthorized(APIStatusError):
    """401: the service wants an API key, and this one is missing or unknown."""


class NotFound(APIStatusError):
    """404: no such job (jobs of other API keys are not found either), or no such route."""


class NoResultYet(NotFound):
    """404: the job has no layout yet, not even a first incumbent."""


class Conflict(APIStatusError):
    """409: an Idempotency-Key reused with another body, or deleting a job that has not
    ended (cancel it first); `problem.kind` tells which."""


class PayloadTooLarge(APIStatusError):
    """413: the problem is larger than the service accepts."""


class InvalidProblem(APIStatusError):
    """422: the service refuses the problem; `errors` names each bad field."""

    @property
    def errors(self) -> list[FieldError]:
        """The bad fields, each with its dotted path (``rooms.2.min_size.0``) and message."""
        return list(self.problem.errors or [])


class RateLimited(APIStatusError):
    """429: the service's queue is full; `retry_after` is its suggested wait in seconds."""

    def __init__(self, problem: ProblemDocument, *, response: httpx.Response,
                 retry_after: float | None) -> None:
        super().__init__(problem, response=response)
        self.retry_after = retry_after


class ServerError(APIStatusError):
    """5xx: the service, or a proxy in front of it, failed or is unavailable."""


class JobFailed(FloorplanError):
    """`Job.wait`: the job ended without a layout. `job.error` (and `code`, `message`)
    says why: ``no_solution`` (nothing found in time), ``worker_died``,
    ``solver_error``, ``retries_exhausted``, ..."""

    def __init__(self, job: JobInfo, problem: ProblemDocument) -> None:
        super().__init__(_describe(problem, None))
        self.job = job
        self.problem = problem

    @property
    def code(self) -> str:
        """The job's error code, e.g. ``infeasible`` or ``worker_died``."""
        return self.job.error.code if self.job.error else "failed"

    @property
    def message(self) -> str:
        """The job's error message."""
        return self.job.error.message if self.job.error else self.problem.detail


class Infeasible(JobFailed):
    """`Job.wait`: no layout satisfies the problem's hard constraints. `reason` says why
    and `findings` lists the impossibilities found; the job's result is a layout without
    rooms whose report explains it too."""

    @property
    def reason(self) -> str:
        """Why no layout exists."""
        return self.message

    @property
    def findings(self) -> list[str]:
        """The cheap impossibilities found (total area, sizes that fit nowhere, ...)."""
        return list(self.job.error.findings) if self.job.error else []

    @property
    def conflict(self) -> ConflictSet | None:
        """A small set of the problem's constraints that cannot hold together: its
        ``explanation`` in words and each constraint's ``path``; None when the service
        had no time to look for one."""
        return self.job.error.conflict if self.job.error else None


class JobCanceled(FloorplanError):
    """`Job.wait`: the job was canceled. Its best layout, if it had one, is still its
    result (`Job.result`)."""

    def __init__(self, job: JobInfo) -> None:
        super().__init__(f"job {job.id} was canceled")
        self.job = job


class WaitTimeout(FloorplanError, TimeoutError):
    """`Job.wait` or `Job.events` ran out of time; the job goes on (cancel it if it
    should not). `job` is its last known state."""

    def __init__(self, job: JobInfo, timeout: float) -> None:
        super().__init__(f"job {job.id} still {job.status.value} after {timeout:g} s")
        self.job = job
        self.timeout = timeout


def _describe(problem: ProblemDocument, status: int | None) -> str:
    """``404 Not Found: job 1234 not found`` plus one line per bad field."""
    head = " ".join(str(part) for part in (status, problem.title) if part)
    text = f"{head}: {problem.detail}" if head and problem.detail else head or problem.detail
    for error in problem.errors or []:
        text += f"\n  {error}"
    return text
