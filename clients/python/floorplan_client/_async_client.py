"""The asynchronous client: `AsyncClient`, its `AsyncJob` handles and `AsyncPage`; the
same calls as the synchronous client, awaited. Runs on asyncio or trio (through
anyio, which httpx2 requires)."""

from __future__ import annotations

from collections.abc import AsyncIterator, Mapping
from types import TracebackType
from typing import Literal, overload

import anyio
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


class AsyncClient(BaseClient):
    """An asynchronous client of a floorplan service: `Client`'s calls, awaited.

    >>> async with AsyncClient("http://127.0.0.1:8000") as fp:   # doctest: +SKIP
    ...     job = await fp.submit("problem.json")
    ...     async for event in job.events():
    ...         print(event)
    ...     layout = await job.wait(timeout=120)

    The arguments are `Client`'s; `http_client` is an `httpx2.AsyncClient`.
    """

    def __init__(
        self, base_url: str | None = None, api_key: str | NotGiven | None = NOT_GIVEN, *,
        timeout: Timeout = C.DEFAULT_TIMEOUT, max_retries: int = C.DEFAULT_MAX_RETRIES,
        headers: Mapping[str, str] | None = None, http_client: httpx.AsyncClient | None = None,
    ) -> None:
        super().__init__(base_url, api_key, timeout=timeout, max_retries=max_retries,
                         headers=headers)
        self._http = http_client or httpx.AsyncClient(timeout=self.timeout)
        self._owns_http = http_client is None

    async def close(self) -> None:
        """Close the connections (not those of an `http_client` you passed in)."""
        if self._owns_http:
            await self._http.aclose()

    async def __aenter__(self) -> AsyncClient:
        return self

    async def __aexit__(self, exc_type: type[BaseException] | None,
                        exc: BaseException | None, tb: TracebackType | None) -> None:
        await self.close()

    # The API.

    async def submit(self, problem: ProblemInput, *, idempotency_key: str | None = None,
                     timeout: Timeout | NotGiven = NOT_GIVEN) -> AsyncJob:
        """Queue a layout job and return its handle: see `Client.submit`."""
        options = self._submit_options(problem, idempotency_key, timeout)
        return AsyncJob(self, self._parse(await self._send(options), JobInfo))

    async def get(self, job_id: str, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> AsyncJob:
        """The handle of an existing job, with its current state: see `Client.get`."""
        return AsyncJob(self, await self._job_info(job_id, timeout))

    async def list(self, *, status: JobStatus | str | None = None,
                   limit: int = C.DEFAULT_PAGE_SIZE, cursor: str | None = None,
                   timeout: Timeout | NotGiven = NOT_GIVEN) -> AsyncPage:
        """The first page of your jobs, newest first; ``async for`` over it goes on
        through the next pages. See `Client.list`."""
        options = RequestOptions("GET", "/v1/layouts",
                                 params=self._list_params(status, limit, cursor),
                                 timeout=timeout)
        page = self._parse(await self._send(options), JobPage)
        return AsyncPage(self, [AsyncJob(self, info) for info in page.data],
                         page.next_cursor, status, limit)

    # Batches: see `Client.submit_batch` and the methods after it.

    async def submit_batch(self, problem: ProblemInput, count: int, *, seed: int = 0,
                           time_limit: float | None = None, vary_program: bool = False,
                           timeout: Timeout | NotGiven = NOT_GIVEN) -> BatchInfo:
        """Queue a batch; see `Client.submit_batch`."""
        options = self._batch_options(problem, count, seed, time_limit, vary_program, timeout)
        return self._parse(await self._send(options), BatchInfo)

    async def get_batch(self, batch_id: str, *, summary: bool = False,
                        timeout: Timeout | NotGiven = NOT_GIVEN) -> BatchInfo:
        """A batch's progress; see `Client.get_batch`."""
        options = RequestOptions("GET", f"/v1/batches/{batch_id}",
                                 params={"summary": "true"} if summary else None,
                                 timeout=timeout)
        return self._parse(await self._send(options), BatchInfo)

    async def batch_results(self, batch_id: str, *, after: int = -1, layouts: bool = True,
                            page_size: int = C.DEFAULT_PAGE_SIZE,
                            timeout: Timeout | NotGiven = NOT_GIVEN
                            ) -> AsyncIterator[BatchLine]:
        """The batch's finished layouts, page after page; see `Client.batch_results`."""
        while True:
            options = RequestOptions(
                "GET", f"/v1/batches/{batch_id}/results", timeout=timeout,
                params={"after": after, "limit": page_size,
                        "layouts": "true" if layouts else "false"})
            response = await self._send(options)
            if response.is_error:
                raise self._status_error(response)
            lines = self._batch_lines(response)
            for line in lines:
                yield line
            if len(lines) < page_size:
                return
            after = lines[-1].index

    async def batch_zip(self, batch_id: str, *, after: int = -1,
                        page_size: int = C.DEFAULT_PAGE_SIZE,
                        timeout: Timeout | NotGiven = NOT_GIVEN) -> bytes:
        """One page of the batch's layouts as a zip; see `Client.batch_zip`."""
        options = RequestOptions("GET", f"/v1/batches/{batch_id}/results", timeout=timeout,
                                 params={"after": after, "limit": page_size, "format": "zip"})
        response = await self._send(options)
        if response.is_error:
            raise self._status_error(response)
        return response.content

    async def cancel_batch(self, batch_id: str, *,
                           timeout: Timeout | NotGiven = NOT_GIVEN) -> BatchInfo:
        """Cancel the batch's layouts not yet finished; see `Client.cancel_batch`."""
        options = RequestOptions("POST", f"/v1/batches/{batch_id}/cancel", timeout=timeout)
        return self._parse(await self._send(options), BatchInfo)

    async def validate(self, problem: ProblemInput, *, explain: bool = False,
                       time_limit: float | None = None,
                       timeout: Timeout | NotGiven = NOT_GIVEN) -> Validation:
        """Check a problem without solving it: see `Client.validate`."""
        options = RequestOptions("POST", "/v1/validate", json=problem_body(problem),
                                 params=self._validate_params(explain, time_limit),
                                 timeout=timeout)
        return self._parse(await self._send(options), Validation)

    # Sending.

    async def _job_info(self, job_id: str, timeout: Timeout | NotGiven) -> JobInfo:
        options = RequestOptions("GET", f"/v1/layouts/{job_id}", timeout=timeout)
        return self._parse(await self._send(options), JobInfo)

    async def _send(self, options: RequestOptions, *, stream: bool = False) -> httpx.Response:
        """Send with retries: `Client._send`, awaited."""
        attempt = 0
        while True:
            request = self._build_request(self._http, options)
            try:
                response = await self._http.send(request, stream=stream)
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
                    await response.aread()
                    return response
                await response.aclose()
            await self._sleep(delay)
            attempt += 1

    async def _sleep(self, seconds: float) -> None:
        await anyio.sleep(seconds)


class AsyncJob(BaseJob):
    """A layout job on the service, for `AsyncClient`: `Job`'s calls, awaited."""

    def __init__(self, client: AsyncClient, info: JobInfo) -> None:
        super().__init__(info)
        self._client = client

    async def refresh(self, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> JobInfo:
        """Fetch the job's current state, keep it as `info` and return it."""
        self.info = await self._client._job_info(self.id, timeout)
        return self.info

    async def events(self, *, last_event_id: int | None = None, poll: bool = False,
                     timeout: float | None = None) -> AsyncIterator[Event]:
        """The job's events until it ends, from its event stream or, where there is
        none (or with `poll`), by polling: see `Job.events`."""
        deadline = deadline_after(timeout)
        tracker = Tracker()
        if not poll:
            try:
                async for event in self._stream(tracker, last_event_id, deadline, timeout):
                    yield event
                return
            except _NoStream:
                pass
        async for event in self._poll(tracker, deadline, timeout):
            yield event

    async def wait(self, timeout: float | None = None) -> Layout:
        """Wait for the job to end and return its layout; raises as `Job.wait` does
        (`Infeasible`, `JobFailed`, `JobCanceled`, `WaitTimeout`)."""
        deadline = deadline_after(timeout)
        pauses = self._client._pauses()
        info = self.info if self.info.status.terminal else await self.refresh()
        while not info.status.terminal:
            left = remaining(deadline)
            if left is not None and left <= 0:
                raise WaitTimeout(info, timeout or 0.0)
            pause = pauses.next()
            await self._client._sleep(pause if left is None else min(pause, left))
            info = await self.refresh()
        failure = self._client._failure(info)
        if failure is not None:
            raise failure
        return await self.result()

    @overload
    async def result(self, format: Literal["json"] = "json", *,
                     storey_height: float | NotGiven = NOT_GIVEN,
                     dxf_layers: DxfLayerNames | NotGiven = NOT_GIVEN,
                     origin: tuple[float, float] | None = None,
                     variant: int | NotGiven = NOT_GIVEN,
                     timeout: Timeout | NotGiven = NOT_GIVEN) -> Layout: ...

    @overload
    async def result(self, format: RenderedFormat, *,
                     storey_height: float | NotGiven = NOT_GIVEN,
                     dxf_layers: DxfLayerNames | NotGiven = NOT_GIVEN,
                     origin: tuple[float, float] | None = None,
                     variant: int | NotGiven = NOT_GIVEN,
                     timeout: Timeout | NotGiven = NOT_GIVEN) -> str: ...

    async def result(self, format: ResultFormat = "json", *,
                     storey_height: float | NotGiven = NOT_GIVEN,
                     dxf_layers: DxfLayerNames | NotGiven = NOT_GIVEN,
                     origin: tuple[float, float] | None = None,
                     variant: int | NotGiven = NOT_GIVEN,
                     timeout: Timeout | NotGiven = NOT_GIVEN) -> Layout | str:
        """The job's layout, or as text its SVG plan, DXF drawing, GeoJSON or IFC model:
        see `Job.result`."""
        options = RequestOptions("GET", f"/v1/layouts/{self.id}/result",
                                 params=result_params(format, storey_height, dxf_layers, variant,
                                                      origin),
                                 timeout=timeout)
        response = await self._client._send(options)
        if format != "json":
            self._client._expect_empty(response)
            return response.text
        return self._client._parse(response, Layout)

    async def cancel(self, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> JobInfo:
        """Ask the service to stop the job: see `Job.cancel`."""
        options = RequestOptions("POST", f"/v1/layouts/{self.id}/cancel", timeout=timeout)
        self.info = self._client._parse(await self._client._send(options), JobInfo)
        return self.info

    async def delete(self, *, timeout: Timeout | NotGiven = NOT_GIVEN) -> None:
        """Remove the job from the service: see `Job.delete`."""
        options = RequestOptions("DELETE", f"/v1/layouts/{self.id}", timeout=timeout)
        self._client._expect_empty(await self._client._send(options))

    # Following: `Job._stream` and `Job._poll`, awaited.

    async def _stream(self, tracker: Tracker, last_event_id: int | None,
                      deadline: float | None, timeout: float | None) -> AsyncIterator[Event]:
        client = self._client
        failures = 0
        while True:
            options = client._events_options(self.id, last_event_id, deadline)
            try:
                response = await client._send(options, stream=True)
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
                    async for sse in httpx.EventSource(response):
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
                    await client._sleep(client._backoff(failures - 1))
                    continue
            finally:
                await response.aclose()
            info = await self.refresh()
            if info.status.terminal:
                for event in tracker.changes(info):
                    yield event
                return
            failures += 1
            if failures > client.max_retries:
                raise _NoStream
            await client._sleep(client._backoff(failures - 1))

    async def _poll(self, tracker: Tracker, deadline: float | None,
                    timeout: float | None) -> AsyncIterator[Event]:
        pauses = self._client._pauses()
        while True:
            info = await self.refresh()
            events = tracker.changes(info)
            for event in events:
                yield event
            if tracker.wants_layout:
                try:
                    incumbent = tracker.incumbent(await self.result())
                except NoResultYet:
                    incumbent = None
                if incumbent is not None:
                    yield incumbent
            if tracker.ended:
                return
            if events:
                pauses.reset()
            left = remaining(deadline)
            if left is not None and left <= 0:
                raise WaitTimeout(info, timeout or 0.0)
            pause = pauses.next()
            await self._client._sleep(pause if left is None else min(pause, left))


class AsyncPage(BasePage[AsyncJob]):
    """A page of jobs, newest first; ``async for`` goes on through the next pages."""

    def __init__(self, client: AsyncClient, data: list[AsyncJob], next_cursor: str | None,
                 status: JobStatus | str | None, limit: int) -> None:
        super().__init__(data, next_cursor, status, limit)
        self._client = client

    async def next_page(self) -> AsyncPage:
        """The page after this one (check `has_next_page` first: the last page has none)."""
        if self.next_cursor is None:
            raise ValueError("this is the last page")
        return await self._client.list(status=self._status, limit=self._limit,
                                       cursor=self.next_cursor)

    async def __aiter__(self) -> AsyncIterator[AsyncJob]:
        page: AsyncPage = self
        while True:
            for job in page.data:
                yield job
            if not page.has_next_page():
                return
            page = await page.next_page()


class _NoStream(Exception):
    """The events endpoint has no stream to give: poll instead."""
