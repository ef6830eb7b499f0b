"""Every malformed header, cursor, body and number is a 4xx problem document (RFC 9457),
never a 500; replayed against a real `floorplan serve` on loopback, then fuzzed over the
OpenAPI schema with invalid headers and query strings included."""

from __future__ import annotations

import base64
from collections.abc import Iterator
from typing import Any

import httpx2 as httpx
import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable
from schemathesis import GenerationMode, checks

from tests.servers import Server
from tests.service.test_service import SMALL, wait

QUIET = {"WORKERS": "1", "FLOORPLAN_SUBDOMAIN_PROCESSES": "1", "FLOORPLAN_MAX_TIME_LIMIT": "2"}
JSON = {"Content-Type": "application/json"}
#: A room the solve cannot give any area: its layout has a room with an empty polygon.
EMPTY_ROOM: dict[str, Any] = {
    "boundary": [[0, 0], [8, 0], [8, 6], [0, 6]],
    "rooms": [{"id": "a", "max_size": [1e-300, 1e-300]}, {"id": "b"}],
    "options": {"time_limit": 1},
}


class Service:
    """The server, and a finished job of it with its events."""

    def __init__(self, server: Server, job_id: str, last_event: int) -> None:
        self.server, self.job_id, self.last_event = server, job_id, last_event
        self.url = server.url


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    server = Server(tmp_path_factory.mktemp("malformed"), **QUIET).start()
    try:
        with httpx.Client(base_url=server.url, timeout=60) as client:
            job = client.post("/v1/layouts", json={**SMALL, "options": {"time_limit": 1}})
            assert job.status_code == 202, job.text
            job_id = job.json()["id"]
            wait(client, job_id)
            stream = client.get(f"/v1/layouts/{job_id}/events").text
            ids = [int(line[4:]) for line in stream.splitlines() if line.startswith("id: ")]
        yield Service(server, job_id, max(ids))
    finally:
        server.stop()


def assert_problem(response: httpx.Response, status: int) -> dict[str, Any]:
    """`response` is a problem document of `status`."""
    assert response.status_code == status, response.text[:500]
    assert response.headers["content-type"] == "application/problem+json"
    problem = response.json()
    assert problem["status"] == status
    return problem


def events(service: Service, last_event_id: bytes | str) -> httpx.Response:
    return httpx.get(f"{service.url}/v1/layouts/{service.job_id}/events", timeout=30,
                     headers=[(b"Last-Event-ID", last_event_id.encode()
                               if isinstance(last_event_id, str) else last_event_id)])


@pytest.mark.parametrize("last_event_id", [b"\xb2", "9" * 5000, "9" * 30, "-1", "1e3", "0x10"])
def test_a_malformed_last_event_id_is_a_422(service: Service, last_event_id: bytes | str) -> None:
    problem = assert_problem(events(service, last_event_id), 422)
    assert [e["field"] for e in problem["errors"]] == ["header.last-event-id"]


def test_a_last_event_id_past_the_jobs_last_event_is_a_400_not_an_empty_stream(
        service: Service) -> None:
    # An id no stream of this job sent: a 30-digit id once gave an empty 200 stream.
    problem = assert_problem(events(service, str(service.last_event + 1)), 400)
    assert f"({service.last_event})" in problem["detail"]
    # The last id sent resumes after it: nothing more for a finished job, a 200.
    resumed = events(service, str(service.last_event))
    assert resumed.status_code == 200 and "event:" not in resumed.text
    earlier = events(service, str(service.last_event - 1))
    assert earlier.status_code == 200 and earlier.text.count("event:") == 1


@pytest.mark.parametrize("cursor", [
    base64.urlsafe_b64encode(b"[" * 3000).decode(),  # RecursionError, once
    base64.urlsafe_b64encode(b"[" * 150).decode(),
    base64.urlsafe_b64encode(b'["x", "y"]').decode(),
    base64.urlsafe_b64encode(b'{"a": 1, "b": 2}').decode(),
    base64.urlsafe_b64encode(b'[null, "x"]').decode(),
    base64.urlsafe_b64encode(b"\xff\xfe").decode(),
    "not base64!",
])
def test_a_malformed_cursor_is_a_4xx(service: Service, cursor: str) -> None:
    response = httpx.get(f"{service.url}/v1/layouts", params={"cursor": cursor}, timeout=30)
    assert_problem(response, 422 if len(cursor) > 256 else 400)


@pytest.mark.parametrize("path", ["/v1/layouts", "/v1/validate"])
@pytest.mark.parametrize("body", [
    b"[" * 100_000,  # RecursionError
    b'{"boundary": [[0, 0], [8, 0], [8, 6], [0, ' + b"9" * 5000 + b']], "rooms": [{"id": "a"}]}',
    b"\xff\xfe{}",
    b"",
])
def test_a_malformed_body_is_a_400(service: Service, path: str, body: bytes) -> None:
    response = httpx.post(service.url + path, content=body, headers=JSON, timeout=30)
    problem = assert_problem(response, 400)
    assert problem["type"].endswith("/malformed-json")


def test_a_layout_with_an_empty_room_exports_in_every_format(service: Service) -> None:
    # The GeoJSON of a room the solve left without area was a 500 (IndexError).
    with httpx.Client(base_url=service.url, timeout=60) as client:
        job = client.post("/v1/layouts", json=EMPTY_ROOM)
        assert job.status_code == 202, job.text
        wait(client, job.json()["id"])
        result = client.get(f"/v1/layouts/{job.json()['id']}/result")
        assert result.status_code == 200
        assert [r["polygon"] for r in result.json()["rooms"] if r["id"] == "a"] == [[]]
        for name in ("svg", "geojson", "dxf", "ifc"):
            exported = client.get(f"/v1/layouts/{job.json()['id']}/result",
                                  params={"format": name})
            assert exported.status_code == 200, (name, exported.text[:300])
        geojson = client.get(f"/v1/layouts/{job.json()['id']}/result",
                             params={"format": "geojson"}).json()
        [empty] = [f for f in geojson["features"] if f["properties"].get("id") == "a"]
        assert empty["geometry"] == {"type": "Polygon", "coordinates": []}


# Fuzzing: arbitrary header and query text, then schemathesis's negative cases.

#: Examples per test or operation: enough for the edges, well under a minute in all.
EXAMPLES = 25
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None,
                suppress_health_check=list(HealthCheck))
#: Header values HTTP can carry: visible Latin-1 and spaces, no controls, and no space
#: at either end (HTTP strips it, and the client refuses to send " ").
HEADER_TEXT = st.text(st.characters(min_codepoint=0x20, max_codepoint=0xFF,
                                    exclude_characters="\x7f"), max_size=60).map(
    lambda text: text.strip(" "))


@pytest.mark.slow
def test_any_last_event_id_is_a_stream_or_a_4xx(service: Service) -> None:
    @FUZZ
    @given(value=HEADER_TEXT | st.integers(min_value=-(10**40), max_value=10**40).map(str))
    def check(value: str) -> None:
        response = events(service, value.encode("latin-1"))
        assert response.status_code in (200, 400, 422), response.text[:300]
        if response.status_code != 200:
            assert response.headers["content-type"] == "application/problem+json"

    check()


@pytest.mark.slow
def test_any_cursor_or_limit_is_a_page_or_a_4xx(service: Service) -> None:
    texts = st.text(max_size=300) | st.binary(max_size=200).map(
        lambda b: base64.urlsafe_b64encode(b).decode())

    @FUZZ
    @given(cursor=texts, limit=st.text(max_size=30) | st.integers().map(str))
    def check(cursor: str, limit: str) -> None:
        response = httpx.get(f"{service.url}/v1/layouts", timeout=30,
                             params={"cursor": cursor, "limit": limit})
        assert response.status_code in (200, 400, 422), response.text[:300]
        if response.status_code != 200:
            assert response.headers["content-type"] == "application/problem+json"

    check()


@pytest.mark.slow
def test_schema_fuzzing_with_invalid_headers_and_query_strings(service: Service) -> None:
    # Negative cases: every parameter (the headers Last-Event-ID, Idempotency-Key,
    # Authorization, X-API-Key; every query string) and body made invalid in turn. The
    # job paths name the finished job, so that its stream ends and its routes get as
    # far as their parameters; DELETE goes last, since it removes that job.
    schema = schemathesis.openapi.from_url(f"{service.url}/openapi.json")
    ops = sorted((op for result in schema.get_all_operations()
                  # Nothing to make invalid in /healthz, /readyz, the page.
                  if (op := result.ok()).path_parameters or op.query or op.headers
                  or op.body),
                 key=lambda op: op.method.upper() == "DELETE")
    fuzzed: list[str] = []
    for op in ops:
        fixed = {"job_id": service.job_id} if "{job_id}" in op.path else None

        @FUZZ
        @given(case=op.as_strategy(GenerationMode.NEGATIVE, path_parameters=fixed))
        def call(case: schemathesis.Case) -> None:
            response = case.call(timeout=30)
            case.validate_response(response, checks=[checks.not_a_server_error])
            if response.status_code >= 400:  # every error an RFC 9457 problem document
                assert response.headers["content-type"] == ["application/problem+json"], \
                    (response.status_code, response.text[:300])

        try:
            call()
        except Unsatisfiable:  # no parameter of it can be invalid (the job id is fixed)
            continue
        fuzzed.append(f"{op.method.upper()} {op.path}")
    assert {"POST /v1/layouts", "GET /v1/layouts", "POST /v1/validate",
            "GET /v1/layouts/{job_id}/events", "GET /v1/layouts/{job_id}/result"} <= set(fuzzed)
