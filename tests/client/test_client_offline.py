"""The Python client's decisions, offline: retries and their pauses, the mapping of
answers to errors, timeouts, API keys, resuming a broken event stream. A
`MockTransport` plays the service; the live tests are tests/client/test_client*.py."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from datetime import UTC, datetime, timedelta
from email.utils import format_datetime
from typing import Any

import httpx2 as httpx
import pytest

import floorplan_client
from floorplan_client import (
    APIConnectionError,
    APIStatusError,
    APITimeoutError,
    BadRequest,
    Client,
    Conflict,
    Infeasible,
    InvalidProblem,
    JobFailed,
    NoResultYet,
    NotFound,
    PayloadTooLarge,
    RateLimited,
    ServerError,
    StatusEvent,
    Unauthorized,
)
from floorplan_client._constants import (
    INITIAL_RETRY_DELAY,
    MAX_RETRY_AFTER,
    RETRY_JITTER,
)

JOB_ID = "6f1d0c55-1e5c-4a57-9a0e-2f6f9b0a8d11"
JOB: dict[str, Any] = {"id": JOB_ID, "status": "queued", "attempts": 0, "time_limit": 2,
                       "created_at": "2025-01-01T00:00:00Z"}
PROBLEM: dict[str, Any] = {"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]],
                           "rooms": [{"id": "a", "min_size": [2, 2]}]}

Handler = Callable[[httpx.Request], httpx.Response]


def problem(status: int, kind: str | None = None, **extra: Any) -> httpx.Response:
    body = {"type": f"/docs/problems/{kind}" if kind else "about:blank", "title": "t",
            "status": status, "detail": f"detail {status}", **extra}
    return httpx.Response(status, json=body, headers={"content-type": "application/problem+json"})


class Recorder:
    """A client on a MockTransport whose pauses are recorded, not slept."""

    def __init__(self, handler: Handler, **options: Any) -> None:
        self.requests: list[httpx.Request] = []
        self.pauses: list[float] = []

        def record(request: httpx.Request) -> httpx.Response:
            self.requests.append(request)
            return handler(request)

        self.client = Client("http://service.test", api_key=options.pop("api_key", None),
                             http_client=httpx.Client(transport=httpx.MockTransport(record)),
                             **options)
        self.client._sleep = self.pauses.append  # type: ignore[method-assign,assignment]


def answers(*responses: httpx.Response | Exception) -> Handler:
    queue: Iterator[httpx.Response | Exception] = iter(responses)

    def handler(request: httpx.Request) -> httpx.Response:
        answer = next(queue)
        if isinstance(answer, Exception):
            raise answer
        return answer

    return handler


def test_a_submit_retried_after_503s_keeps_its_idempotency_key() -> None:
    r = Recorder(answers(problem(503), problem(503), httpx.Response(202, json=JOB)))
    job = r.client.submit(PROBLEM)
    assert job.id == JOB_ID
    keys = {request.headers["idempotency-key"] for request in r.requests}
    assert len(r.requests) == 3 and len(keys) == 1
    assert [json.loads(request.content) for request in r.requests] == [PROBLEM] * 3
    # Exponential backoff with jitter: 0.5 s then 1 s, each times [0.75, 1].
    for n, pause in enumerate(r.pauses):
        assert INITIAL_RETRY_DELAY * 2 ** n * (1 - RETRY_JITTER) <= pause \
            <= INITIAL_RETRY_DELAY * 2 ** n
    assert len(r.pauses) == 2


def test_retry_after_is_honoured_in_seconds_or_as_a_date_up_to_a_cap() -> None:
    soon = format_datetime(datetime.now(UTC) + timedelta(seconds=30), usegmt=True)
    r = Recorder(answers(httpx.Response(429, headers={"Retry-After": "3"}),
                         httpx.Response(503, headers={"Retry-After": soon}),
                         httpx.Response(200, json={"data": [JOB]})))
    assert [job.id for job in r.client.list()] == [JOB_ID]
    assert r.pauses[0] == 3 and 25 < r.pauses[1] <= 30
    late = Recorder(answers(httpx.Response(429, headers={"Retry-After": str(
        int(MAX_RETRY_AFTER) + 1)})))
    with pytest.raises(RateLimited) as caught:
        late.client.list()
    assert caught.value.retry_after == MAX_RETRY_AFTER + 1 and late.pauses == []


def test_nothing_else_is_retried_and_max_retries_zero_retries_nothing() -> None:
    r = Recorder(answers(problem(409, "idempotency-conflict")))
    with pytest.raises(Conflict):
        r.client.submit(PROBLEM)
    assert len(r.requests) == 1
    once = Recorder(answers(problem(503)), max_retries=0)
    with pytest.raises(ServerError):
        once.client.list()
    assert len(once.requests) == 1


@pytest.mark.parametrize(("status", "kind", "error"), [
    (400, "malformed-json", BadRequest),
    (401, "unauthorized", Unauthorized),
    (404, "job-not-found", NotFound),
    (404, "no-result-yet", NoResultYet),
    (409, "job-not-finished", Conflict),
    (413, "body-too-large", PayloadTooLarge),
    (422, "invalid-problem", InvalidProblem),
    (429, "queue-full", RateLimited),
    (500, None, ServerError),
    (418, None, APIStatusError),
])
def test_each_status_maps_to_its_error_carrying_the_problem_document(
    status: int, kind: str | None, error: type[APIStatusError],
) -> None:
    r = Recorder(answers(problem(status, kind)), max_retries=0)
    with pytest.raises(error) as caught:
        r.client.get(JOB_ID)
    assert type(caught.value) is error
    assert caught.value.status_code == status and caught.value.problem.status == status
    assert caught.value.problem.kind == (kind or "")
    assert caught.value.problem.detail == f"detail {status}"


def test_an_error_page_without_a_problem_document_gets_one_made() -> None:
    r = Recorder(answers(httpx.Response(502, text="<html>Bad gateway</html>")), max_retries=0)
    with pytest.raises(ServerError) as caught:
        r.client.list()
    assert caught.value.problem.title == "Bad Gateway"
    assert caught.value.problem.detail == "<html>Bad gateway</html>"


def test_invalid_problem_lists_its_fields() -> None:
    errors = [{"field": "rooms.0.min_size.0", "loc": ["rooms", 0, "min_size", 0],
               "message": "too large", "type": "x"}]
    r = Recorder(answers(problem(422, "invalid-problem", errors=errors)))
    with pytest.raises(InvalidProblem) as caught:
        r.client.submit(PROBLEM)
    assert [str(e) for e in caught.value.errors] == ["rooms.0.min_size.0: too large"]


def test_connection_failures_are_retried_then_raised_typed() -> None:
    r = Recorder(answers(httpx.ConnectError("refused"), httpx.ConnectError("refused"),
                         httpx.ConnectError("refused")))
    with pytest.raises(APIConnectionError) as caught:
        r.client.list()
    assert len(r.requests) == 3 and len(r.pauses) == 2
    assert isinstance(caught.value.__cause__, httpx.ConnectError)
    slow = Recorder(answers(httpx.ReadTimeout("slow"), httpx.Response(200, json={"data": []})))
    assert list(slow.client.list()) == []
    late = Recorder(answers(httpx.ReadTimeout("slow")), max_retries=0)
    with pytest.raises(APITimeoutError):
        late.client.list()


def test_every_call_takes_a_timeout_none_meaning_none() -> None:
    r = Recorder(lambda request: httpx.Response(200, json=JOB), timeout=7)
    r.client.get(JOB_ID)
    r.client.get(JOB_ID, timeout=0.5)
    r.client.get(JOB_ID, timeout=None)
    r.client.get(JOB_ID, timeout=httpx.Timeout(3, connect=1))
    seen = [request.extensions["timeout"] for request in r.requests]
    assert seen[0] == {"connect": 7, "read": 7, "write": 7, "pool": 7}
    assert seen[1]["read"] == 0.5 and seen[2]["read"] is None
    assert seen[3] == {"connect": 1, "read": 3, "write": 3, "pool": 3}


def test_the_api_key_comes_from_the_caller_or_the_environment(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("FLOORPLAN_API_KEY", "from-env")
    monkeypatch.setenv("FLOORPLAN_URL", "http://env.test:9000/")
    seen: list[httpx.Request] = []

    def handler(request: httpx.Request) -> httpx.Response:
        seen.append(request)
        return httpx.Response(200, json=JOB)

    for api_key in (floorplan_client.NOT_GIVEN, "given", None):
        http = httpx.Client(transport=httpx.MockTransport(handler))
        with Client(api_key=api_key, http_client=http) as fp:
            fp.get(JOB_ID)
    assert [r.headers.get("authorization") for r in seen] == [
        "Bearer from-env", "Bearer given", None]
    assert str(seen[0].url) == f"http://env.test:9000/v1/layouts/{JOB_ID}"


def finished(status: str, termination: str | None, code: str | None) -> dict[str, Any]:
    error = {"code": code, "message": f"because {code}", "findings": []} if code else None
    return {**JOB, "status": status, "termination": termination, "error": error}


@pytest.mark.parametrize(("job", "error", "code"), [
    (finished("failed", "infeasible", "infeasible"), Infeasible, "infeasible"),
    (finished("failed", "no_solution", "no_solution"), JobFailed, "no_solution"),
    (finished("failed", None, "worker_died"), JobFailed, "worker_died"),
])
def test_wait_raises_by_how_the_job_failed(job: dict[str, Any], error: type[JobFailed],
                                           code: str) -> None:
    r = Recorder(answers(httpx.Response(202, json=JOB), httpx.Response(200, json=job)))
    with pytest.raises(error) as caught:
        r.client.submit(PROBLEM).wait(timeout=5)
    assert type(caught.value) is error and caught.value.code == code
    assert caught.value.message == f"because {code}"
    assert caught.value.problem.type == f"/docs/problems/{code}"


def sse(*events: tuple[int, str, dict[str, Any]]) -> httpx.Response:
    text = "".join(f"id: {i}\nevent: {kind}\ndata: {json.dumps(data)}\n\n"
                   for i, kind, data in events)
    return httpx.Response(200, text=text, headers={"content-type": "text/event-stream"})


def test_a_broken_stream_is_resumed_after_the_last_event() -> None:
    progress = {"phase": "level", "level": 1, "elapsed": 0.1}
    r = Recorder(answers(
        httpx.Response(202, json=JOB),
        sse((1, "status", {"status": "running"}), (2, "progress", progress)),  # cut here
        httpx.Response(200, json={**JOB, "status": "running"}),
        sse((3, "status", {"status": "succeeded", "termination": "optimal"})),
    ))
    events = list(r.client.submit(PROBLEM).events())
    assert [e.id for e in events] == [1, 2, 3]
    assert isinstance(events[-1], StatusEvent) and events[-1].status.value == "succeeded"
    streams = [q for q in r.requests if q.url.path.endswith("/events")]
    assert "last-event-id" not in streams[0].headers
    assert streams[1].headers["last-event-id"] == "2"


def test_an_unknown_job_is_not_found_rather_than_polled() -> None:
    r = Recorder(answers(httpx.Response(202, json=JOB), problem(404, "job-not-found")))
    with pytest.raises(NotFound):
        list(r.client.submit(PROBLEM).events())


def test_every_public_name_can_be_imported() -> None:
    for name in floorplan_client.__all__:
        assert getattr(floorplan_client, name) is not None
    with pytest.raises(AttributeError):
        floorplan_client.Nothing  # noqa: B018


def test_every_public_call_has_a_docstring() -> None:
    import importlib
    import inspect
    import pkgutil

    import floorplan_client.cli

    missing = []
    names = [(name, getattr(floorplan_client, name)) for name in floorplan_client.__all__]
    for info in pkgutil.iter_modules(floorplan_client.cli.__path__, "floorplan_client.cli."):
        module = importlib.import_module(info.name)
        names += [(f"{info.name.removeprefix('floorplan_client.')}.{name}", value)
                  for name, value in vars(module).items()
                  if not name.startswith("_") and getattr(value, "__module__", "") == info.name]
    for name, value in names:
        if not (inspect.isclass(value) or inspect.isfunction(value)):
            continue
        if not inspect.getdoc(value):
            missing.append(name)
        if inspect.isclass(value) and value.__module__.startswith("floorplan_client"):
            for attr, member in vars(value).items():
                if attr.startswith("_") or attr.startswith("model_"):
                    continue
                if (inspect.isfunction(member) or isinstance(member, property)) \
                        and not member.__doc__:
                    missing.append(f"{name}.{attr}")
    assert missing == []


def test_the_summary_line_tells_the_corridors_and_their_walks() -> None:
    """A layout with corridors: `floorplan submit`'s last line gives their share, the
    longest walk to an exit and each route's walk (none where no corridor joins it)."""
    from types import SimpleNamespace
    from typing import cast

    from floorplan_client._client import Job
    from floorplan_client.cli.display import summary_line
    from floorplan_client.models import Layout

    report = {"coverage": 1.0, "uncovered_area": 0.0, "valid": True,
              "termination": "optimal", "solve_time": 1.0,
              "egress": {"corridor_share": 0.251, "max_travel": 42.28,
                         "routes": [36.04, None]}}
    job = cast(Job, SimpleNamespace(id="j1"))
    line = summary_line(job, Layout.model_validate({"name": "f", "report": report}))
    assert "corridors 25.1%  longest walk 42.3 m  routes 36.0, none m" in line
    plain = Layout.model_validate({"name": "f", "report": {**report, "egress": None}})
    assert "corridors" not in summary_line(job, plain)
