"""A Python client of the floorplan layout service.

    from floorplan_client import Client

    with Client("http://127.0.0.1:8000") as fp:
        job = fp.submit("examples/apartment-5.json")   # a path, a dict or a Problem
        for event in job.events():                     # status, progress, incumbent
            print(event)
        layout = job.wait(timeout=120)                 # a floorplan_client.models.Layout
        svg = job.result(format="svg")

`AsyncClient` has the same calls, awaited. Errors are `FloorplanError`s, each about
something the service said carrying its problem document (see `_exceptions`).

The names below are imported on first use, not with the package: the `floorplan`
command imports `floorplan_client.cli` to offer ``submit``, and ``floorplan solve``
must not load numpy (through `floorplan_client.models`) before it has set up its Ctrl-C handling.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from floorplan_client._async_client import AsyncClient, AsyncJob, AsyncPage
    from floorplan_client._client import Client, Job, Page
    from floorplan_client._core import NOT_GIVEN, NotGiven, ProblemInput, Timeout
    from floorplan_client._exceptions import (
        APIConnectionError,
        APIStatusError,
        APITimeoutError,
        BadRequest,
        Conflict,
        FloorplanError,
        Infeasible,
        InvalidProblem,
        JobCanceled,
        JobFailed,
        NoResultYet,
        NotFound,
        PayloadTooLarge,
        ProblemFileError,
        RateLimited,
        ServerError,
        Unauthorized,
        WaitTimeout,
    )
    from floorplan_client.types import (
        ErrorInfo,
        Event,
        FieldError,
        IncumbentEvent,
        JobInfo,
        JobStatus,
        ProblemDocument,
        Progress,
        ProgressEvent,
        StatusEvent,
        Validation,
    )

__version__ = "0.1.0"

_WHERE = {
    "floorplan_client._client": ("Client", "Job", "Page"),
    "floorplan_client._async_client": ("AsyncClient", "AsyncJob", "AsyncPage"),
    "floorplan_client._core": ("NOT_GIVEN", "NotGiven", "ProblemInput", "Timeout"),
    "floorplan_client._exceptions": (
        "APIConnectionError", "APIStatusError", "APITimeoutError", "BadRequest", "Conflict",
        "FloorplanError", "Infeasible", "InvalidProblem", "JobCanceled", "JobFailed",
        "NoResultYet", "NotFound", "PayloadTooLarge", "ProblemFileError", "RateLimited",
        "ServerError", "Unauthorized", "WaitTimeout",
    ),
    "floorplan_client.types": (
        "BatchInfo", "BatchLine", "ErrorInfo", "Event", "FieldError", "IncumbentEvent",
        "JobInfo", "JobStatus",
        "ProblemDocument", "Progress", "ProgressEvent", "StatusEvent", "Validation",
    ),
}
_MODULE_OF = {name: module for module, names in _WHERE.items() for name in names}

__all__ = [
    "NOT_GIVEN",
    "APIConnectionError",
    "APIStatusError",
    "APITimeoutError",
    "AsyncClient",
    "AsyncJob",
    "AsyncPage",
    "BadRequest",
    "BatchInfo",
    "BatchLine",
    "Client",
    "Conflict",
    "ErrorInfo",
    "Event",
    "FieldError",
    "FloorplanError",
    "IncumbentEvent",
    "Infeasible",
    "InvalidProblem",
    "Job",
    "JobCanceled",
    "JobFailed",
    "JobInfo",
    "JobStatus",
    "NoResultYet",
    "NotFound",
    "NotGiven",
    "Page",
    "PayloadTooLarge",
    "ProblemDocument",
    "ProblemFileError",
    "ProblemInput",
    "Progress",
    "ProgressEvent",
    "RateLimited",
    "ServerError",
    "StatusEvent",
    "Timeout",
    "Unauthorized",
    "Validation",
    "WaitTimeout",
]


def __getattr__(name: str) -> Any:
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'floorplan_client' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
