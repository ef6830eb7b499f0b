"""The Python client (clients/python) against real service processes on loopback, in
both modes (embedded, and an API node with Celery workers): every call, one error of
each kind, cancel, retries and the polling fallback.
The async client has its own file, mirroring this one; so has `floorplan submit`."""

from __future__ import annotations

import json
import re
import shutil
import socket
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from floorplan_client import (
    APIConnectionError,
    APITimeoutError,
    Client,
    Conflict,
    IncumbentEvent,
    Infeasible,
    InvalidProblem,
    Job,
    JobCanceled,
    JobStatus,
    NoResultYet,
    NotFound,
    ProblemFileError,
    ProgressEvent,
    RateLimited,
    ServerError,
    StatusEvent,
    Unauthorized,
    WaitTimeout,
)
from floorplan_client.models import Layout, Problem, Termination
from tests.paths import ROOT
from tests.servers import AnyServer, service
from tests.service.test_service import LONG, SMALL

KEY = "alpha"
#: Two rooms whose minimum sizes need 32 m² of a 24 m² flat: infeasible at once.
CROWDED: dict[str, Any] = {**SMALL, "name": "crowded", "adjacency": [],
                           "rooms": [{"id": k, "min_size": [4, 4]} for k in "ab"]}


CLIENT_BACKENDS = ["embedded"]


# The client speaks HTTP only: what the service does with a job in either mode is
# tests/service/test_service.py's to prove (both modes); here the embedded service
# stands for both, which keeps a Celery cluster's start and stop out of these modules.
@pytest.fixture(scope="module", params=CLIENT_BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def server(backend: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[AnyServer]:
    s = service(backend, tmp_path_factory.mktemp("data"), FLOORPLAN_API_KEYS=f"{KEY}, beta").start()
    yield s
    s.stop()


@pytest.fixture
def fp(server: AnyServer) -> Iterator[Client]:
    with Client(server.url, api_key=KEY) as c:
        yield c


def first_incumbent(job: Job, timeout: float = 30) -> Layout:
    deadline = time.monotonic() + timeout
    while True:
        try:
            return job.result()
        except NoResultYet:
            assert time.monotonic() < deadline, "no incumbent in time"
            time.sleep(0.1)


# Every call.


@pytest.mark.slow
def test_submit_follow_the_events_wait_and_fetch_the_layout(fp: Client) -> None:
    job = fp.submit(SMALL)
    assert job.info.status is JobStatus.QUEUED and len(job.id) == 36
    events = list(job.events(timeout=60))
    assert isinstance(events[0], StatusEvent) and events[0].status is JobStatus.RUNNING
    assert isinstance(events[-1], StatusEvent) and events[-1].status is JobStatus.SUCCEEDED
    assert any(isinstance(e, ProgressEvent) for e in events)
    incumbent = next(e for e in events if isinstance(e, IncumbentEvent))
    assert {r.id for r in incumbent.layout.rooms} == {"living", "bed"}
    ids = [e.id for e in events]
    assert all(i is not None for i in ids) and ids == sorted(ids)  # type: ignore[type-var]
    assert str(events[-1]).startswith("status succeeded (")
    assert str(incumbent).startswith("incumbent objective ")

    layout = job.wait(timeout=60)
    assert isinstance(layout, Layout) and layout.report.valid
    assert job.status is JobStatus.SUCCEEDED and job.info.termination is not None
    assert job.info.started_at and job.info.finished_at and job.info.progress is not None
    svg = job.result(format="svg")
    assert svg.lstrip().startswith("<") and "<svg" in svg
    ifc = job.result(format="ifc", storey_height=3.3)
    assert "FILE_SCHEMA(('IFC4'))" in ifc and "IFCBUILDINGSTOREY" in ifc and "3.3" in ifc
    assert "ROOM_BEDROOM" in job.result(format="dxf", dxf_layers="room-type")
    again = fp.get(job.id)
    assert again.id == job.id and again.status is JobStatus.SUCCEEDED
    assert again.refresh().finished_at == job.info.finished_at

    # Resuming after the second event replays only what came later.
    assert [e.id for e in again.events(last_event_id=ids[1])] == ids[2:]


@pytest.mark.slow
def test_a_problem_can_be_a_dict_a_path_or_a_model(fp: Client, tmp_path: Path) -> None:
    path = tmp_path / "small.json"
    path.write_text(json.dumps(SMALL))
    model = Problem.model_validate(SMALL)
    jobs = [fp.submit(path), fp.submit(str(path)), fp.submit(model)]
    for job in jobs:
        assert {r.id for r in job.wait(timeout=60).rooms} == {"living", "bed"}
    (tmp_path / "broken.json").write_text('{"rooms": [')
    with pytest.raises(ProblemFileError, match=r"broken.json: invalid JSON at line 1"):
        fp.submit(tmp_path / "broken.json")
    with pytest.raises(ProblemFileError, match="no such file"):
        fp.submit(tmp_path / "missing.json")
    with pytest.raises(TypeError):
        fp.submit(42)  # type: ignore[arg-type]


@pytest.mark.slow
def test_events_by_polling_give_the_same_kinds(fp: Client) -> None:
    job = fp.submit(SMALL)
    events = list(job.events(poll=True, timeout=60))
    statuses = [e.status for e in events if isinstance(e, StatusEvent)]
    assert statuses[-1] is JobStatus.SUCCEEDED and statuses == list(dict.fromkeys(statuses))
    assert all(e.id is None for e in events)
    assert job.wait().report.valid


class NoEventStream(httpx.HTTPTransport):
    """A proxy in front of the service that has no event streams (404 for them)."""

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        if request.url.path.endswith("/events"):
            return httpx.Response(404, text="<html>Not Found</html>")
        return super().handle_request(request)


@pytest.mark.slow
def test_events_fall_back_to_polling_where_there_is_no_stream(server: AnyServer) -> None:
    http = httpx.Client(transport=NoEventStream())
    with Client(server.url, api_key=KEY, http_client=http) as fp, http:
        job = fp.submit(SMALL)
        events = list(job.events(timeout=60))
    assert isinstance(events[-1], StatusEvent) and events[-1].status is JobStatus.SUCCEEDED
    assert all(e.id is None for e in events)  # made from polling


def test_validate_gives_a_verdict_without_solving(fp: Client) -> None:
    assert fp.validate(SMALL).valid
    bad = fp.validate({**SMALL, "rooms": [{"id": "a", "min_size": [3, 2], "max_size": [2, 2]}]})
    assert not bad.valid and bad.errors[0].field == "rooms.0.min_size.0"
    crowded = fp.validate(CROWDED)
    assert not crowded.valid and "minimum sizes need" in crowded.findings[0]


def test_validate_hands_back_a_templated_problem_expanded(fp: Client) -> None:
    verdict = fp.validate({**SMALL, "adjacency": [], "template": "residential",
                           "rooms": ["living", "bedroom"]})
    assert verdict.valid and isinstance(verdict.problem, Problem)
    assert [r.id for r in verdict.problem.rooms] == ["living", "bedroom"]
    assert all(r.target_size for r in verdict.problem.rooms)
    assert fp.validate(verdict.problem).problem == verdict.problem


@pytest.mark.slow
def test_list_pages_through_the_jobs_newest_first(fp: Client) -> None:
    ids = [fp.submit({**SMALL, "name": f"page-{k}"}).id for k in range(3)]
    page = fp.list(limit=2)
    assert len(page.data) == 2 and page.has_next_page()
    assert page.next_page().data[0].id != page.data[0].id
    seen = [job.id for job in page]  # iterating goes through every page
    assert seen.index(ids[2]) < seen.index(ids[1]) < seen.index(ids[0])
    assert len(seen) == len(set(seen))
    for job_id in ids:
        fp.get(job_id).wait(timeout=60)
    done = list(fp.list(status="succeeded"))
    assert done and all(job.status is JobStatus.SUCCEEDED for job in done)
    assert ids[0] in {job.id for job in done}


@pytest.mark.slow
def test_cancel_keeps_the_incumbent_and_delete_refuses_a_running_job(fp: Client) -> None:
    job = fp.submit(LONG)
    with pytest.raises(WaitTimeout) as timed_out:
        job.wait(timeout=0.3)
    assert isinstance(timed_out.value, TimeoutError)
    assert timed_out.value.job.status in (JobStatus.QUEUED, JobStatus.RUNNING)
    running = first_incumbent(job)
    assert running.report.termination is Termination.IN_PROGRESS
    with pytest.raises(Conflict) as conflict:
        job.delete()
    assert conflict.value.problem.kind == "job-not-finished"
    job.cancel()
    with pytest.raises(JobCanceled):
        job.wait(timeout=60)
    # Interrupted by the cancel, before the end of its time limit.
    assert job.status is JobStatus.CANCELED and job.info.termination is Termination.INTERRUPTED
    assert job.result().report.termination is Termination.INTERRUPTED
    assert job.cancel().status is JobStatus.CANCELED  # again: nothing changes
    job.delete()
    with pytest.raises(NotFound):
        job.refresh()


# One error of each kind.


def test_an_invalid_problem_names_its_bad_fields(fp: Client) -> None:
    with pytest.raises(InvalidProblem) as caught:
        fp.submit({**SMALL, "adjacency": [{"a": "living", "b": "ghost"}]})
    err = caught.value
    assert err.status_code == 422 and [e.field for e in err.errors] == ["adjacency.0.b"]
    assert err.problem.status == 422 and err.problem.kind == "invalid-problem"
    assert "adjacency.0.b: unknown room id 'ghost'" in str(err)


def test_an_id_that_is_no_uuid_is_not_found_rather_than_an_invalid_problem(
        fp: Client) -> None:
    for job_id in ("nope", "0000", "x" * 100):
        with pytest.raises(NotFound) as caught:
            fp.get(job_id)
        assert caught.value.problem.kind == "job-not-found"


@pytest.mark.slow
def test_unknown_jobs_and_other_keys_jobs_are_not_found(fp: Client, server: AnyServer) -> None:
    with pytest.raises(NotFound) as caught:
        fp.get("00000000-0000-0000-0000-000000000000")
    assert caught.value.problem.kind == "job-not-found"
    mine = fp.submit(SMALL)
    with Client(server.url, api_key="beta") as other, pytest.raises(NotFound):
        other.get(mine.id)
    mine.wait(timeout=60)


@pytest.mark.slow
def test_an_idempotency_key_gives_one_job_and_refuses_another_body(fp: Client) -> None:
    first = fp.submit(SMALL, idempotency_key="order-42")
    assert fp.submit(SMALL, idempotency_key="order-42").id == first.id
    with pytest.raises(Conflict) as caught:
        fp.submit({**SMALL, "name": "else"}, idempotency_key="order-42")
    assert caught.value.problem.kind == "idempotency-conflict"
    first.wait(timeout=60)


@pytest.mark.slow
def test_an_infeasible_problem_raises_infeasible_with_its_findings(fp: Client) -> None:
    job = fp.submit(CROWDED)
    with pytest.raises(Infeasible) as caught:
        job.wait(timeout=60)
    err = caught.value
    assert err.code == "infeasible" and err.job.status is JobStatus.FAILED
    assert "minimum sizes need" in err.findings[0] and err.reason
    assert err.problem.kind == "infeasible" and err.problem.instance == f"/v1/layouts/{job.id}"
    assert job.result().rooms == []  # the report without rooms says why too


def test_a_missing_or_wrong_api_key_is_unauthorized(server: AnyServer) -> None:
    for key in (None, "gamma"):
        with Client(server.url, api_key=key) as fp, pytest.raises(Unauthorized) as caught:
            fp.list()
        assert caught.value.status_code == 401 and caught.value.problem.kind == "unauthorized"


class LostAnswers(httpx.HTTPTransport):
    """Passes requests on to the service, then loses the next `lose` answers: the client
    gets 503 with `Retry-After: 0` instead, as from a failing proxy."""

    def __init__(self, lose: int = 0) -> None:
        super().__init__()
        self.lose = lose
        self.keys: list[str | None] = []

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        response = super().handle_request(request)
        self.keys.append(request.headers.get("idempotency-key"))
        if self.lose <= 0:
            return response
        self.lose -= 1
        response.read()
        response.close()
        return httpx.Response(503, headers={"Retry-After": "0"},
                              json={"type": "about:blank", "title": "Service Unavailable",
                                    "status": 503, "detail": "the upstream went away"})


@pytest.mark.slow
def test_a_retried_submit_makes_one_job_with_one_idempotency_key(server: AnyServer) -> None:
    transport = LostAnswers()
    http = httpx.Client(transport=transport)
    with Client(server.url, api_key=KEY, http_client=http) as fp, http:
        before = {job.id for job in fp.list()}
        transport.keys.clear()
        transport.lose = 2
        job = fp.submit(SMALL)
        assert len(transport.keys) == 3 and len(set(transport.keys)) == 1
        assert transport.keys[0]
        assert {j.id for j in fp.list()} - before == {job.id}  # three posts, one job
        job.wait(timeout=60)


def test_a_failing_service_is_a_server_error_after_the_retries(server: AnyServer) -> None:
    transport = LostAnswers(lose=10)
    http = httpx.Client(transport=transport)
    with Client(server.url, api_key=KEY, max_retries=2, http_client=http) as fp, http, \
            pytest.raises(ServerError) as caught:
        fp.validate(SMALL)
    assert len(transport.keys) == 3
    assert caught.value.status_code == 503
    assert caught.value.problem.detail == "the upstream went away"


@pytest.mark.slow
def test_no_service_is_a_connection_error_and_silence_a_timeout() -> None:
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        port = listener.getsockname()[1]
    with Client(f"http://127.0.0.1:{port}", api_key=None, max_retries=1) as fp, \
            pytest.raises(APIConnectionError) as refused:
        fp.list()
    assert not isinstance(refused.value, APITimeoutError)
    assert refused.value.request.url.port == port
    with socket.socket() as silent:  # accepts connections (backlog), never answers
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        url = f"http://127.0.0.1:{silent.getsockname()[1]}"
        with Client(url, api_key=None, max_retries=0) as fp, pytest.raises(APITimeoutError):
            fp.list(timeout=0.3)


@pytest.mark.slow
def test_a_full_queue_is_rate_limited_honouring_retry_after(backend: str, tmp_path: Path) -> None:
    s = service(backend, tmp_path, FLOORPLAN_QUEUE_LIMIT="1", WORKERS="1").start()
    try:
        with Client(s.url, api_key=None, max_retries=1) as fp:
            busy = fp.submit({**LONG, "options": {"time_limit": 30}})
            while busy.refresh().status is JobStatus.QUEUED:
                time.sleep(0.05)
            waiting = fp.submit(SMALL)
            with pytest.raises(NoResultYet) as no_result:
                waiting.result()
            assert no_result.value.problem.title == "No layout yet"
            pauses: list[float] = []
            fp._sleep = pauses.append  # type: ignore[method-assign,assignment]
            with pytest.raises(RateLimited) as caught:
                fp.submit(SMALL)
            assert caught.value.retry_after == 5 and pauses == [5.0]  # the service's word
            assert caught.value.problem.kind == "queue-full"
            del fp._sleep
            busy.cancel()
            waiting.wait(timeout=60)
    finally:
        s.stop()


@pytest.mark.slow
def test_the_readme_examples_run(server: AnyServer, tmp_path: Path,
                                 monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    guide = (ROOT / "clients" / "python" / "README.md").read_text()
    section = guide.split("\n## Use it from Python\n")[1]
    examples = re.findall(r"```python\n(.*?)```", section.split("\n## ")[0], re.DOTALL)
    assert len(examples) == 2
    (tmp_path / "examples").mkdir()
    shutil.copy(ROOT / "examples" / "apartment-5.json", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    for code in examples:
        code = code.replace('"http://127.0.0.1:8000", api_key=None',
                            f"{server.url!r}, api_key={KEY!r}")
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    out = capsys.readouterr().out
    assert "valid=True" in out and "incumbent objective" in out and "status succeeded" in out
    assert "minimum sizes need" in out
    assert "<svg" in (tmp_path / "plan.svg").read_text()
