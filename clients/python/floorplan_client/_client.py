"""The synchronous client: `Client`, the `Job` handles it gives out, and `Page`."""

from __future__ import annotations

import time
from collections.abc import Iterator, Mapping
from types import TracebackType
from typing import Literal, overload

import httpx2 as httpx

from floorplan_client import _constants as C
from floorplan_client._core import (
    NOT_GIVEN,
    RETRYABLE_ERRORS,
    BaseClient,
    BaseJob,
    BasePage,
    DxfLayerNames,
    NotGiven,
    ProblemInput,
    RenderedFormat,
    RequestOptions,
    ResultFormat,
    Timeout,
    problem_body,
    result_params,
)
from floorplan_client._deadlines import deadline_after, expired, remaining
from floorplan_client._exceptions import APIConnectionError, NoResultYet, WaitTimeout
from floorplan_client._following import Tracker
from floorplan_client.types import (
    BatchInfo,
    BatchLine,
    Event,
    JobInfo,
    JobPage,
    JobStatus,
    Layout,
    Validation,
)


class Client(BaseClient):
    """A synchronous client of a floorplan service.

    >>> with Client("http://127.0.0.1:8000") as fp:      # doctest: +SKIP
    ...     layout = fp.submit("problem.json").wait(timeout=120)

    `base_url` defaults to ``$FLOORPLAN_URL``, then ``http://127.0.0.1:8000``.
    `api_key` defaults to ``$FLOORPLAN_API_KEY``; None sends none. `timeout` bounds
    each HTTP request (seconds, an `httpx2.Timeout`, or None for no limit); every call
    takes its own `timeout` too. Connection failures and answers 408, 429, 500, 502,
    503 and 504 are retried up to `max_retries` times, after `Retry-After` when the
    service gives one, else after an exponential backoff with jitter. `http_client`
    lets you bring your own `httpx2.Client` (proxies, transports, event hooks); it is
    not closed by `close`.
    """

    def __init__(
        self, base_url: str | None = None, api_key: str | NotGiven | None = NOT_GIVEN, *,
        timeout: Timeout = C.DEFAULT_TIMEOUT, max_retries: int = C.DEFAULT_MAX_RETRIES,
        headers: Mapping[str, str] | None = None, http_client: httpx.Client | None = None,
    ) -> None:
        super().__init__(base_url, api_key, timeout=timeout, max_retries=max_retries,
                         headers=headers)
        self._http = http_client or httpx.Client(timeout=self.timeout)
        self._owns_http = http_client is None

    def close(self) -> None:
        """Close the connections (not those of an `http_client` you passed in)."""
        if self._owns_http:
            self._http.close()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    # The API.

    def submit(self, problem: ProblemInput, *, idempotency_key: str | None = None,
               timeout: Timeout | NotGiven = NOT_GIVEN) -> Job:
        """Queue a layout job and return its handle (status ``queued``).

        `problem` is a `models.Problem`, a dict of its JSON, or the path of a JSON
        file. Retries send the same `idempotency_key` (a new UUID when not given), so a
        retried submission never makes two jobs; reusing a key with another problem is
        `Conflict`. Raises `InvalidProblem` (with `errors`, one per bad field) for a
        problem the service refuses, `RateLimited` when its queue stays full, and
        `ProblemFileError` for a file that cannot be read as JSON."""
        options = self._submit_options(problem, idempotency_key, timeout)
        return Job(self, self._parse(self._send(options), JobInfo))

    def get(self, job_id: str, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> Job:
        """The handle of an existing job, with its current state; `NotFound` if there is
        no such job (or it belongs to another API key)."""
        return Job(self, self._job_info(job_id, timeout))

    def list(self, *, status: JobStatus | str | None = None,
             limit: int = C.DEFAULT_PAGE_SIZE, cursor: str | None = None,
             timeout: Timeout | NotGiven = NOT_GIVEN) -> Page:
        """The first page of your jobs, newest first, optionally only those in `status`.

        Iterating the page goes on through the next pages (`limit` jobs per request):
        ``for job in fp.list(status="running"): job.cancel()``."""
        options = RequestOptions("GET", "/v1/layouts",
                                 params=self._list_params(status, limit, cursor),
                                 timeout=timeout)
        page = self._parse(self._send(options), JobPage)
        return Page(self, [Job(self, info) for info in page.data], page.next_cursor,
                    status, limit)

    def validate(self, problem: ProblemInput, *, explain: bool = False,
                 time_limit: float | None = None,
                 timeout: Timeout | NotGiven = NOT_GIVEN) -> Validation:
        """Check a problem without solving it. An ill-formed problem is not an error
        here: the verdict has ``valid`` False and its `errors`; `findings` list the
        cheap impossibilities (total area, sizes that fit nowhere, ...). With
        `explain`, the service also asks SCIP for up to `time_limit` seconds (its
        default: 3) whether a layout exists (`feasible`) and, when none does, which
        constraints cannot hold together (`conflict`)."""
        options = RequestOptions("POST", "/v1/validate", json=problem_body(problem),
                                 params=self._validate_params(explain, time_limit),
                                 timeout=timeout)
        return self._parse(self._send(options), Validation)

    # Batches.

    def submit_batch(self, problem: ProblemInput, count: int, *, seed: int = 0,
                     time_limit: float | None = None, vary_program: bool = False,
                     timeout: Timeout | NotGiven = NOT_GIVEN) -> BatchInfo:
        """Queue `count` layouts of one brief, seeds `seed`, `seed` + 1, ..., each its own
        plan (``options.diverse``); with `vary_program` each its own programme drawn from
        a templated brief. `time_limit` is per draw of a layout (one that is not good is
        drawn again, twice at most). `RateLimited` when the queue cannot take them all."""
        options = self._batch_options(problem, count, seed, time_limit, vary_program, timeout)
        return self._parse(self._send(options), BatchInfo)

    def get_batch(self, batch_id: str, *, summary: bool = False,
                  timeout: Timeout | NotGiven = NOT_GIVEN) -> BatchInfo:
        """A batch's progress (its layouts by status); with `summary` also the valid
        layouts and the distinct plans and adjacency graphs among them."""
        options = RequestOptions("GET", f"/v1/batches/{batch_id}",
                                 params={"summary": "true"} if summary else None,
                                 timeout=timeout)
        return self._parse(self._send(options), BatchInfo)

    def batch_results(self, batch_id: str, *, after: int = -1, layouts: bool = True,
                      page_size: int = C.DEFAULT_PAGE_SIZE,
                      timeout: Timeout | NotGiven = NOT_GIVEN) -> Iterator[BatchLine]:
        """The batch's finished layouts with index above `after`, in index order, page
        after page until none are left (layouts finishing meanwhile included)."""
        while True:
            options = RequestOptions(
                "GET", f"/v1/batches/{batch_id}/results", timeout=timeout,
                params={"after": after, "limit": page_size,
                        "layouts": "true" if layouts else "false"})
            response = self._send(options)
            if response.is_error:
                raise self._status_error(response)
            lines = self._batch_lines(response)
            yield from lines
            if len(lines) < page_size:
                return
            after = lines[-1].index

    def batch_zip(self, batch_id: str, *, after: int = -1,
                  page_size: int = C.DEFAULT_PAGE_SIZE,
                  timeout: Timeout | NotGiven = NOT_GIVEN) -> bytes:
        """One page of the batch's finished layouts as a zip (those with index above
        `after`, at most `page_size`): a JSON file per layout and `results.ndjson`."""
        options = RequestOptions("GET", f"/v1/batches/{batch_id}/results", timeout=timeout,
                                 params={"after": after, "limit": page_size, "format": "zip"})
        response = self._send(options)
        if response.is_error:
            raise self._status_error(response)
        return response.content

    def cancel_batch(self, batch_id: str, *,
                     timeout: Timeout | NotGiven = NOT_GIVEN) -> BatchInfo:
        """Cancel the batch's layouts not yet finished; finished ones stay."""
        options = RequestOptions("POST", f"/v1/batches/{batch_id}/cancel", timeout=timeout)
        return self._parse(self._send(options), BatchInfo)

    # Sending.

    def _job_info(self, job_id: str, timeout: Timeout | NotGiven) -> JobInfo:
        options = RequestOptions("GET", f"/v1/layouts/{job_id}", timeout=timeout)
        return self._parse(self._send(options), JobInfo)

    def _send(self, options: RequestOptions, *, stream: bool = False) -> httpx.Response:
        """Send with retries: the one retry loop of this client. An error answer that is
        not retried (or no longer) is returned, read, for the caller to raise."""
        attempt = 0
        while True:
            request = self._build_request(self._http, options)
            try:
                response = self._http.send(request, stream=stream)
            except RETRYABLE_ERRORS as err:
                delay = self._retry_delay(attempt, None)
                if delay is None:
                    raise self._connection_error(err, request) from err
            except httpx.TransportError as err:
                raise self._connection_error(err, request) from err
            else:
                if not response.is_error:
                    return response
                delay = self._retry_delay(attempt, response)
                if delay is None:
                    response.read()
                    return response
                response.close()
            self._sleep(delay)
            attempt += 1

    def _sleep(self, seconds: float) -> None:
        time.sleep(seconds)


class Job(BaseJob):
    """A layout job on the service: follow it, wait for it, fetch its layout, cancel
    or delete it. `id`, `status` and `info` are as last seen; `refresh` looks again."""

    def __init__(self, client: Client, info: JobInfo) -> None:
        super().__init__(info)
        self._client = client

    def refresh(self, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> JobInfo:
        """Fetch the job's current state (status, termination, progress, error,
        timestamps), keep it as `info` and return it."""
        self.info = self._client._job_info(self.id, timeout)
        return self.info

    def events(self, *, last_event_id: int | None = None, poll: bool = False,
               timeout: float | None = None) -> Iterator[Event]:
        """The job's events until it ends: `StatusEvent`, `ProgressEvent` and
        `IncumbentEvent` (with the incumbent layout), the last one its terminal status.

        They come from the service's event stream, which is resumed after the last
        event (``Last-Event-ID``) if the connection breaks. Where there is no event
        stream (a proxy without it), or with `poll`, the job is polled instead, with
        exponential backoff and jitter, and the same kinds of events are made from what
        changed (those have no `id`). `last_event_id` skips the events up to that one.
        `timeout` bounds the whole iteration in seconds: past it, `WaitTimeout`."""
        deadline = deadline_after(timeout)
        tracker = Tracker()
        if not poll:
            try:
                yield from self._stream(tracker, last_event_id, deadline, timeout)
                return
            except _NoStream:
                pass
        yield from self._poll(tracker, deadline, timeout)

    def wait(self, timeout: float | None = None) -> Layout:
        """Wait for the job to end (polling, with backoff and jitter) and return its
        layout.

        Raises `Infeasible` when no layout can exist (with `reason` and `findings`),
        `JobFailed` when the job failed otherwise (`code`: ``no_solution``,
        ``worker_died``, ...), `JobCanceled` when it was canceled, and `WaitTimeout`
        after `timeout` seconds (None: no limit; the job goes on)."""
        deadline = deadline_after(timeout)
        pauses = self._client._pauses()
        info = self.info if self.info.status.terminal else self.refresh()
        while not info.status.terminal:
            left = remaining(deadline)
            if left is not None and left <= 0:
                raise WaitTimeout(info, timeout or 0.0)
            pause = pauses.next()
            self._client._sleep(pause if left is None else min(pause, left))
            info = self.refresh()
        failure = self._client._failure(info)
        if failure is not None:
            raise failure
        return self.result()

    @overload
    def result(self, format: Literal["json"] = "json", *,
               storey_height: float | NotGiven = NOT_GIVEN,
               dxf_layers: DxfLayerNames | NotGiven = NOT_GIVEN,
               origin: tuple[float, float] | None = None,
               variant: int | NotGiven = NOT_GIVEN,
               timeout: Timeout | NotGiven = NOT_GIVEN) -> Layout: ...

    @overload
    def result(self, format: RenderedFormat, *,
               storey_height: float | NotGiven = NOT_GIVEN,
               dxf_layers: DxfLayerNames | NotGiven = NOT_GIVEN,
               origin: tuple[float, float] | None = None,
               variant: int | NotGiven = NOT_GIVEN,
               timeout: Timeout | NotGiven = NOT_GIVEN) -> str: ...

    def result(self, format: ResultFormat = "json", *,
               storey_height: float | NotGiven = NOT_GIVEN,
               dxf_layers: DxfLayerNames | NotGiven = NOT_GIVEN,
               origin: tuple[float, float] | None = None,
               variant: int | NotGiven = NOT_GIVEN,
               timeout: Timeout | NotGiven = NOT_GIVEN) -> Layout | str:
        """The job's layout as a `models.Layout`; with ``format="svg"`` its plan as SVG
        text, with ``"dxf"`` a DXF drawing (metres; `dxf_layers` "ncs", the AIA / NCS
        layers, by default, or "room-type"), with ``"geojson"`` GeoJSON text (RFC 7946) in the
        problem's local metres, or with `origin` (latitude, longitude of the plan's
        origin, +y due north) in WGS84 longitude and latitude, with ``"ifc"`` an IFC4
        building model (STEP text, storeys `storey_height` metres apart, 3 by default).
        While the job runs this is the best
        layout so far (``report.termination`` ``in_progress``); `NoResultYet` before
        there is one. With `variant` (a problem with ``options.variants``), that design
        variant of the final layout, 0 the best (`Layout.variants` holds them all); a
        `NotFound` when the job found fewer."""
        options = RequestOptions("GET", f"/v1/layouts/{self.id}/result",
                                 params=result_params(format, storey_height, dxf_layers, variant,
                                                      origin),
                                 timeout=timeout)
        response = self._client._send(options)
        if format != "json":
            self._client._expect_empty(response)
            return response.text
        return self._client._parse(response, Layout)

    def cancel(self, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> JobInfo:
        """Ask the service to stop the job; the solve stops within moments and its best
        layout becomes the result (status ``canceled``, termination ``interrupted``). A
        job that has ended is left as it is. Returns (and keeps) the job's state."""
        options = RequestOptions("POST", f"/v1/layouts/{self.id}/cancel", timeout=timeout)
        self.info = self._client._parse(self._client._send(options), JobInfo)
        return self.info

    def delete(self, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> None:
        """Remove the job and its layout from the service. A job that has not ended is
        `Conflict`: cancel it first."""
        options = RequestOptions("DELETE", f"/v1/layouts/{self.id}", timeout=timeout)
        self._client._expect_empty(self._client._send(options))

    # Following.

    def _stream(self, tracker: Tracker, last_event_id: int | None, deadline: float | None,
                timeout: float | None) -> Iterator[Event]:
        client = self._client
        failures = 0
        while True:
            options = client._events_options(self.id, last_event_id, deadline)
            try:
                response = client._send(options, stream=True)
            except APIConnectionError as err:
                if expired(deadline):
                    raise WaitTimeout(self.info, timeout or 0.0) from err
                raise
            try:
                if client._no_stream(response):
                    raise _NoStream
                if response.is_error:
                    raise client._status_error(response)
                try:
                    for sse in httpx.EventSource(response):
                        event = client._event(sse)
                        if event is None:
                            continue
                        if event.id is not None:
                            last_event_id = event.id
                        failures = 0
                        tracker.seen(event)
                        yield event
                        if tracker.ended:
                            return
                except RETRYABLE_ERRORS as err:
                    if expired(deadline):
                        raise WaitTimeout(self.info, timeout or 0.0) from err
                    failures += 1
                    if failures > client.max_retries:
                        raise _NoStream from err
                    client._sleep(client._backoff(failures - 1))
                    continue
            finally:
                response.close()
            # The stream ended before a terminal status: cut by a proxy, or the job
            # ended between two looks of the service. Ask, then resume if need be.
            info = self.refresh()
            if info.status.terminal:
                for event in tracker.changes(info):
                    yield event
                return
            failures += 1
            if failures > client.max_retries:
                raise _NoStream
            client._sleep(client._backoff(failures - 1))

    def _poll(self, tracker: Tracker, deadline: float | None,
              timeout: float | None) -> Iterator[Event]:
        pauses = self._client._pauses()
        while True:
            info = self.refresh()
            events = tracker.changes(info)
            yield from events
            if tracker.wants_layout:
                try:
                    event = tracker.incumbent(self.result())
                except NoResultYet:
                    event = None
                if event is not None:
                    yield event
            if tracker.ended:
                return
            if events:
                pauses.reset()
            left = remaining(deadline)
            if left is not None and left <= 0:
                raise WaitTimeout(info, timeout or 0.0)
            pause = pauses.next()
            self._client._sleep(pause if left is None else min(pause, left))


class Page(BasePage[Job]):
    """A page of jobs, newest first. Iterating it yields every job from this page on,
    fetching the next pages as it goes; `data` is this page's jobs only."""

    def __init__(self, client: Client, data: list[Job], next_cursor: str | None,
                 status: JobStatus | str | None, limit: int) -> None:
        super().__init__(data, next_cursor, status, limit)
        self._client = client

    def next_page(self) -> Page:
        """The page after this one (check `has_next_page` first: the last page has none)."""
        if self.next_cursor is None:
            raise ValueError("this is the last page")
        return self._client.list(status=self._status, limit=self._limit,
                                 cursor=self.next_cursor)

    def __iter__(self) -> Iterator[Job]:
        page: Page = self
        while True:
            yield from page.data
            if not page.has_next_page():
                return
            page = page.next_page()


class _NoStream(Exception):
    """The events endpoint has no stream to give: poll instead."""

