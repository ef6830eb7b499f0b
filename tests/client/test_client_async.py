"""The asynchronous client against a real `floorplan serve` process: the calls of
tests/client/test_client.py, awaited (each test runs its own event loop)."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable, Iterator
from typing import Any, TypeVar

import httpx2 as httpx
import pytest

from floorplan_client import (
    AsyncClient,
    AsyncJob,
    Conflict,
    IncumbentEvent,
    Infeasible,
    InvalidProblem,
    JobCanceled,
    JobStatus,
    NoResultYet,
    NotFound,
    ServerError,
    StatusEvent,
    WaitTimeout,
)
from floorplan_client.models import Layout, Problem, Termination
from tests.client.test_client import CROWDED
from tests.servers import AnyServer, service
from tests.service.test_service import LONG, SMALL

T = TypeVar("T")


CLIENT_BACKENDS = ["embedded"]


# The client speaks HTTP only: what the service does with a job in either mode is
# tests/service/test_service.py's to prove (both modes); here the embedded service
# stands for both, which keeps a Celery cluster's start and stop out of these modules.
@pytest.fixture(scope="module", params=CLIENT_BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def server(backend: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[AnyServer]:
    s = service(backend, tmp_path_factory.mktemp("data")).start()
    yield s
    s.stop()


def run(server: AnyServer, test: Callable[[AsyncClient], Awaitable[T]], **options: Any) -> T:
    async def main() -> T:
        async with AsyncClient(server.url, api_key=None, **options) as fp:
            return await test(fp)

    return asyncio.run(main())


@pytest.mark.slow
def test_submit_follow_the_events_wait_and_fetch_the_layout(server: AnyServer) -> None:
    async def test(fp: AsyncClient) -> None:
        job = await fp.submit(SMALL)
        assert isinstance(job, AsyncJob) and job.status is JobStatus.QUEUED
        events = [event async for event in job.events(timeout=60)]
        assert isinstance(events[-1], StatusEvent) and events[-1].status is JobStatus.SUCCEEDED
        assert any(isinstance(e, IncumbentEvent) for e in events)
        layout = await job.wait(timeout=60)
        assert isinstance(layout, Layout) and layout.report.valid
        assert "<svg" in await job.result(format="svg")
        again = await fp.get(job.id)
        assert again.status is JobStatus.SUCCEEDED
        assert (await again.refresh()).finished_at == (await job.refresh()).finished_at
        resumed = [e.id async for e in again.events(last_event_id=events[1].id)]
        assert resumed == [e.id for e in events[2:]]
        polled = [e async for e in (await fp.submit(Problem.model_validate(SMALL)))
                  .events(poll=True, timeout=60)]
        assert isinstance(polled[-1], StatusEvent) and polled[-1].status is JobStatus.SUCCEEDED

    run(server, test)


@pytest.mark.slow
def test_validate_and_list(server: AnyServer) -> None:
    async def test(fp: AsyncClient) -> None:
        assert (await fp.validate(SMALL)).valid
        assert not (await fp.validate(CROWDED)).valid
        ids = [(await fp.submit({**SMALL, "name": f"async-{k}"})).id for k in range(3)]
        page = await fp.list(limit=2)
        assert len(page.data) == 2 and page.has_next_page()
        seen = [job.id async for job in page]
        assert seen.index(ids[2]) < seen.index(ids[1]) < seen.index(ids[0])
        for job_id in ids:
            await (await fp.get(job_id)).wait(timeout=60)
        done = [j async for j in await fp.list(status=JobStatus.SUCCEEDED)]
        assert done and all(j.status is JobStatus.SUCCEEDED for j in done)

    run(server, test)


@pytest.mark.slow
def test_cancel_keeps_the_incumbent(server: AnyServer) -> None:
    async def test(fp: AsyncClient) -> None:
        job = await fp.submit(LONG)
        with pytest.raises(WaitTimeout):
            await job.wait(timeout=0.3)
        deadline = time.monotonic() + 30
        while True:
            try:
                await job.result()
                break
            except NoResultYet:
                assert time.monotonic() < deadline
                await asyncio.sleep(0.1)
        with pytest.raises(Conflict):
            await job.delete()
        await job.cancel()
        with pytest.raises(JobCanceled):
            await job.wait(timeout=60)
        assert job.info.termination is Termination.INTERRUPTED
        assert (await job.result()).report.termination is Termination.INTERRUPTED
        await job.delete()
        with pytest.raises(NotFound):
            await fp.get(job.id)

    run(server, test)


def test_errors_are_typed_as_in_the_sync_client(server: AnyServer) -> None:
    async def test(fp: AsyncClient) -> None:
        with pytest.raises(InvalidProblem) as invalid:
            await fp.submit({**SMALL, "adjacency": [{"a": "living", "b": "ghost"}]})
        assert [e.field for e in invalid.value.errors] == ["adjacency.0.b"]
        with pytest.raises(NotFound):
            await fp.get("00000000-0000-0000-0000-000000000000")
        job = await fp.submit(CROWDED)
        with pytest.raises(Infeasible) as infeasible:
            await job.wait(timeout=60)
        assert "minimum sizes need" in infeasible.value.findings[0]

    run(server, test)


class Unavailable(httpx.AsyncBaseTransport):
    """A proxy whose service is away: 503 with Retry-After 0, every time."""

    def __init__(self) -> None:
        self.calls = 0

    async def handle_async_request(self, request: httpx.Request) -> httpx.Response:
        self.calls += 1
        return httpx.Response(503, headers={"Retry-After": "0"}, text="<html>away</html>")


def test_a_failing_service_is_a_server_error_after_the_retries(server: AnyServer) -> None:
    transport = Unavailable()

    async def test(fp: AsyncClient) -> None:
        with pytest.raises(ServerError) as caught:
            await fp.list()
        assert caught.value.problem.title == "Service Unavailable"
        assert caught.value.problem.detail == "<html>away</html>"

    run(server, test, max_retries=3, http_client=httpx.AsyncClient(transport=transport))
    assert transport.calls == 4
