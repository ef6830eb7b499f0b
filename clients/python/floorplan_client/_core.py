"""The I/O-free core that `Client` and `AsyncClient` share: configuration, building
requests, reading answers into models or typed errors, deciding retries and pauses,
and turning polled job states into the events a stream would have sent (the pauses
and the tracker of a followed job are _following.py's). The two clients only send,
sleep and loop."""

from __future__ import annotations

import json
import os
import random
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from email.utils import parsedate_to_datetime
from http import HTTPStatus
from pathlib import Path
from typing import Any, Final, Generic, TypeVar

import httpx2 as httpx
from pydantic import BaseModel, ValidationError

from floorplan_client import __version__
from floorplan_client import _constants as C
from floorplan_client._deadlines import remaining
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
)
from floorplan_client._following import Pauses
from floorplan_client.models.formats import DxfLayers, FormatName, RenderedFormatName
from floorplan_client.types import (
    BatchLine,
    Event,
    JobInfo,
    JobStatus,
    Problem,
    ProblemDocument,
    Termination,
    event_from,
)

T = TypeVar("T", bound=BaseModel)


class NotGiven:
    """The type of `NOT_GIVEN`: an argument left out, as opposed to None ("none, off")."""

    _instance: NotGiven | None = None

    def __new__(cls) -> NotGiven:
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __bool__(self) -> bool:
        return False

    def __repr__(self) -> str:
        return "NOT_GIVEN"


#: Leave an argument to the client's default (``timeout``) or to the environment
#: (``api_key``); None turns it off.
NOT_GIVEN: Final = NotGiven()

#: A timeout in seconds (one number for connect, read, write and pool), an
#: `httpx2.Timeout`, or None for none at all.
Timeout = float | httpx.Timeout | None
#: A problem: a `models.Problem`, a dict of its JSON, or the path of a JSON file.
ProblemInput = Problem | Mapping[str, Any] | str | os.PathLike[str]

#: What `Job.result` can fetch: the layout (a `models.Layout`), or as text an SVG plan,
#: a DXF drawing, GeoJSON or an IFC model (`models.formats`).
ResultFormat = FormatName
#: The formats `Job.result` returns as text, rendered from the layout.
RenderedFormat = RenderedFormatName
#: The DXF drawing's layer names: "ncs" (A-WALL, A-AREA, ...) or "room-type".
DxfLayerNames = DxfLayers


def result_params(format: ResultFormat, storey_height: float | NotGiven,
                  dxf_layers: DxfLayerNames | NotGiven,
                  variant: int | NotGiven = NOT_GIVEN,
                  origin: tuple[float, float] | None = None) -> dict[str, Any]:
    """The query of GET /v1/layouts/{id}/result: the format, and the options given
    (the service's defaults stand for the others)."""
    params: dict[str, Any] = {"format": format}
    if not isinstance(variant, NotGiven):
        params["variant"] = variant
    if not isinstance(storey_height, NotGiven):
        params["storey_height"] = storey_height
    if not isinstance(dxf_layers, NotGiven):
        params["dxf_layers"] = dxf_layers
    if origin is not None:
        params["origin"] = f"{origin[0]!r},{origin[1]!r}"
    return params

#: Failures in sending or receiving that another attempt may well not meet.
RETRYABLE_ERRORS: tuple[type[httpx.TransportError], ...] = (
    httpx.TimeoutException, httpx.NetworkError, httpx.RemoteProtocolError,
)

_STATUS_ERRORS: dict[int, type[APIStatusError]] = {
    400: BadRequest, 401: Unauthorized, 404: NotFound, 409: Conflict,
    413: PayloadTooLarge, 422: InvalidProblem, 429: RateLimited,
}


@dataclass(frozen=True)
class RequestOptions:
    """One API call, before it becomes an `httpx2.Request` (anew for each attempt)."""

    method: str
    path: str
    json: Any = None
    params: Mapping[str, Any] | None = None
    headers: Mapping[str, str] = field(default_factory=dict)
    timeout: Timeout | NotGiven = NOT_GIVEN


class BaseClient:
    """What `Client` and `AsyncClient` share; no I/O happens here."""

    def __init__(
        self, base_url: str | None, api_key: str | NotGiven | None, *,
        timeout: Timeout, max_retries: int, headers: Mapping[str, str] | None,
    ) -> None:
        if max_retries < 0:
            raise ValueError("max_retries must be 0 or more")
        self.base_url = (base_url or os.environ.get(C.BASE_URL_ENV) or C.DEFAULT_BASE_URL) \
            .rstrip("/")
        if isinstance(api_key, NotGiven):
            api_key = os.environ.get(C.API_KEY_ENV) or None
        self.api_key = api_key
        self.timeout = as_timeout(timeout)
        self.max_retries = max_retries
        self._headers = dict(headers or {})
        self._random = random.Random()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.base_url!r})"

    # Requests.

    def _default_headers(self) -> dict[str, str]:
        headers = {"Accept": "application/json",
                   "User-Agent": f"floorplan-client/{__version__} httpx2/{httpx.__version__}"}
        if self.api_key:
            headers["Authorization"] = f"Bearer {self.api_key}"
        return headers | self._headers

    def _build_request(self, http: httpx.Client | httpx.AsyncClient,
                       options: RequestOptions) -> httpx.Request:
        timeout = self.timeout if isinstance(options.timeout, NotGiven) \
            else as_timeout(options.timeout)
        return http.build_request(
            options.method, self.base_url + options.path, json=options.json,
            params=dict(options.params) if options.params else None,
            headers=self._default_headers() | dict(options.headers), timeout=timeout,
        )

    def _submit_options(self, problem: ProblemInput, idempotency_key: str | None,
                        timeout: Timeout | NotGiven) -> RequestOptions:
        """One submission; its Idempotency-Key goes with every retry of it."""
        key = idempotency_key or _new_key()
        return RequestOptions("POST", "/v1/layouts", json=problem_body(problem),
                              headers={"Idempotency-Key": key}, timeout=timeout)

    @staticmethod
    def _batch_options(problem: ProblemInput, count: int, seed: int,
                       time_limit: float | None, vary_program: bool,
                       timeout: Timeout | NotGiven) -> RequestOptions:
        body: dict[str, Any] = {"problem": problem_body(problem), "count": count, "seed": seed,
                                "vary_program": vary_program}
        if time_limit is not None:
            body["time_limit"] = time_limit
        return RequestOptions("POST", "/v1/batches", json=body, timeout=timeout)

    @staticmethod
    def _batch_lines(response: httpx.Response) -> list[BatchLine]:
        """The lines of a page of a batch's results (NDJSON)."""
        return [BatchLine.model_validate_json(line) for line in response.text.splitlines()
                if line.strip()]

    @staticmethod
    def _list_params(status: JobStatus | str | None, limit: int,
                     cursor: str | None) -> dict[str, Any]:
        params: dict[str, Any] = {"limit": limit}
        if status is not None:
            params["status"] = JobStatus(status).value
        if cursor:
            params["cursor"] = cursor
        return params

    @staticmethod
    def _validate_params(explain: bool, time_limit: float | None) -> dict[str, Any] | None:
        """None without `explain`: the cheap check is the plain POST it always was."""
        if not explain:
            return None
        params: dict[str, Any] = {"explain": "true"}
        if time_limit is not None:
            params["time_limit"] = time_limit
        return params

    def _events_options(self, job_id: str, last_event_id: int | None,
                        deadline: float | None) -> RequestOptions:
        headers = {"Accept": "text/event-stream", "Cache-Control": "no-store"}
        if last_event_id is not None:
            headers["Last-Event-ID"] = str(last_event_id)
        return RequestOptions("GET", f"/v1/layouts/{job_id}/events", headers=headers,
                              timeout=self._until(deadline))

    def _until(self, deadline: float | None) -> httpx.Timeout:
        """The client's timeout, its reads cut short to end by `deadline`."""
        left = remaining(deadline)
        if left is None:
            return self.timeout
        read = self.timeout.read
        read = max(left, 0.01) if read is None else min(read, max(left, 0.01))
        return httpx.Timeout(connect=self.timeout.connect, read=read, write=self.timeout.write,
                             pool=self.timeout.pool)

    # Retries.

    def _retry_delay(self, attempt: int, response: httpx.Response | None) -> float | None:
        """Seconds to wait before another attempt after attempt number `attempt` (0 for
        the first) failed with `response` (None: no answer), or None not to retry."""
        if attempt >= self.max_retries:
            return None
        if response is None:
            return self._backoff(attempt)
        if response.status_code not in C.RETRY_STATUSES:
            return None
        after = retry_after(response.headers)
        if after is None:
            return self._backoff(attempt)
        return after if after <= C.MAX_RETRY_AFTER else None

    def _backoff(self, attempt: int) -> float:
        delay = min(C.INITIAL_RETRY_DELAY * 2.0 ** attempt, C.MAX_RETRY_DELAY)
        return delay * self._random.uniform(1 - C.RETRY_JITTER, 1)

    def _pauses(self) -> Pauses:
        return Pauses(self._random)

    # Answers.

    def _parse(self, response: httpx.Response, model: type[T]) -> T:
        """The answer as `model`, or its typed error."""
        if response.is_error:
            raise self._status_error(response)
        try:
            return model.model_validate_json(response.content)
        except ValidationError as err:
            raise APIStatusError(
                ProblemDocument(title="Unexpected answer", status=response.status_code,
                                detail=f"not a {model.__name__}: {err}"), response=response,
            ) from err

    def _expect_empty(self, response: httpx.Response) -> None:
        if response.is_error:
            raise self._status_error(response)

    def _status_error(self, response: httpx.Response) -> APIStatusError:
        """The typed error of a 4xx or 5xx answer (whose body has been read)."""
        problem = problem_document(response)
        status = response.status_code
        if status == 429:
            return RateLimited(problem, response=response, retry_after=retry_after(
                response.headers))
        if status == 404 and problem.kind == C.NO_RESULT_YET:
            return NoResultYet(problem, response=response)
        cls = _STATUS_ERRORS.get(status) or (ServerError if status >= 500 else APIStatusError)
        return cls(problem, response=response)

    @staticmethod
    def _connection_error(err: httpx.TransportError, request: httpx.Request) -> FloorplanError:
        cls = APITimeoutError if isinstance(err, httpx.TimeoutException) else APIConnectionError
        return cls(f"{request.method} {request.url}: {type(err).__name__}: {err or 'no answer'}",
                   request=request)

    @staticmethod
    def _no_stream(response: httpx.Response) -> bool:
        """True when this answer to the events endpoint means "no event stream here"
        (rather than an error to raise): polling should do instead."""
        if response.is_error:
            if response.status_code not in C.NO_STREAM_STATUSES:
                return False
            return problem_document(response).kind != C.JOB_NOT_FOUND
        media = response.headers.get("content-type", "").partition(";")[0].strip().lower()
        return media != "text/event-stream"

    @staticmethod
    def _event(sse: httpx.ServerSentEvent) -> Event | None:
        try:
            data = json.loads(sse.data) if sse.data else {}
        except json.JSONDecodeError:
            return None
        event_id = int(sse.id) if sse.id.isdigit() else None
        return event_from(sse.event, event_id, data) if isinstance(data, dict) else None

    @staticmethod
    def _failure(info: JobInfo) -> FloorplanError | None:
        """What `wait` raises for a job that ended as `info`; None if it succeeded."""
        if info.status is JobStatus.SUCCEEDED:
            return None
        if info.status is JobStatus.CANCELED:
            return JobCanceled(info)
        code = info.error.code if info.error else "failed"
        infeasible = info.termination is Termination.INFEASIBLE or code == "infeasible"
        problem = ProblemDocument(
            type=f"{C.PROBLEM_TYPES}{code}",
            title="No layout exists" if infeasible else "The job failed",
            detail=info.error.message if info.error else f"job {info.id} failed",
            instance=f"/v1/layouts/{info.id}",
        )
        return (Infeasible if infeasible else JobFailed)(info, problem)


class BaseJob:
    """What `Job` and `AsyncJob` share: the id and the last known state."""

    def __init__(self, info: JobInfo) -> None:
        self.info = info

    @property
    def id(self) -> str:
        """The job's id (a UUID), as the service named it."""
        return self.info.id

    @property
    def status(self) -> JobStatus:
        """The status when the job was last looked at (`refresh` looks again)."""
        return self.info.status

    def __repr__(self) -> str:
        return f"{type(self).__name__}(id={self.id!r}, status={self.status.value!r})"


_Job = TypeVar("_Job", bound=BaseJob)


class BasePage(Generic[_Job]):
    """A page of jobs: `data`, newest first, and the cursor of the next page."""

    def __init__(self, data: list[_Job], next_cursor: str | None,
                 status: JobStatus | str | None, limit: int) -> None:
        self.data = data
        self.next_cursor = next_cursor
        self._status = status
        self._limit = limit

    def has_next_page(self) -> bool:
        """True when another page follows this one."""
        return self.next_cursor is not None

    def __repr__(self) -> str:
        return f"{type(self).__name__}({len(self.data)} jobs, next_cursor={self.next_cursor!r})"


# Helpers.


def as_timeout(timeout: Timeout | httpx.Timeout) -> httpx.Timeout:
    """An `httpx2.Timeout` from seconds, a Timeout, or None (no limit)."""
    return timeout if isinstance(timeout, httpx.Timeout) else httpx.Timeout(timeout)


def retry_after(headers: httpx.Headers) -> float | None:
    """`Retry-After` in seconds (from seconds or an HTTP date), or None."""
    value = headers.get("retry-after")
    if not value:
        return None
    try:
        return max(float(value), 0.0)
    except ValueError:
        pass
    try:
        return max(parsedate_to_datetime(value).timestamp() - time.time(), 0.0)
    except (TypeError, ValueError, OverflowError):
        return None


def problem_document(response: httpx.Response) -> ProblemDocument:
    """The answer's RFC 9457 document; one made from the status when it has none."""
    status = response.status_code
    try:
        body = response.json()
        if isinstance(body, dict):
            return ProblemDocument.model_validate({"status": status, **body})
    except (ValueError, ValidationError):
        pass
    try:
        title = HTTPStatus(status).phrase
    except ValueError:
        title = "Error"
    return ProblemDocument(title=title, status=status, detail=response.text[:500].strip())


def problem_body(problem: ProblemInput) -> Any:
    """The JSON to send for a problem given as a `Problem`, a dict or a path. Any pydantic
    model dumps as itself, so the service's own `floorplan.models.Problem` goes too."""
    if isinstance(problem, Problem | BaseModel):
        return problem.model_dump(mode="json")
    if isinstance(problem, Mapping):
        return dict(problem)
    if isinstance(problem, str | os.PathLike):
        return read_problem_file(Path(problem))
    raise TypeError(f"a problem is a Problem, a dict or a path, not "
                    f"{type(problem).__name__}")


def read_problem_file(path: Path) -> Any:
    """The JSON of a problem file; `ProblemFileError` names what is wrong with it."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ProblemFileError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise ProblemFileError(f"{path}: is a directory, not a problem file") from None
    except UnicodeDecodeError as err:
        raise ProblemFileError(f"{path}: not UTF-8 text (byte {err.start})") from None
    except OSError as err:
        raise ProblemFileError(f"{path}: cannot read: {err.strerror or err}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise ProblemFileError(
            f"{path}: invalid JSON at line {err.lineno}, column {err.colno}: {err.msg}"
        ) from None


def _new_key() -> str:
    return str(uuid.uuid4())
