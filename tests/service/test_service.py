"""The HTTP service, tested against real processes on loopback, in both modes: the
embedded `floorplan serve`, and an API node with Celery workers on the machine's Redis
and PostgreSQL (tests/servers.py). Every test runs against both backends."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import ifcopenshell
import ifcopenshell.util.element
import pytest

from tests.servers import BACKENDS, AnyServer, service

TERMINAL = {"succeeded", "failed", "canceled"}

SMALL: dict[str, Any] = {
    "name": "two-rooms",
    "boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
    "rooms": [
        {"id": "living", "type": "living", "min_size": [2, 2], "max_size": [5, 4],
         "target_size": [3.5, 4]},
        {"id": "bed", "type": "bedroom", "min_size": [2, 2], "max_size": [4, 4],
         "target_size": [2.5, 4]},
    ],
    "adjacency": [{"a": "living", "b": "bed"}],
    "options": {"time_limit": 2},
}

# Twelve offices: a first layout within a fraction of a second, then seconds of search
# before it stalls, so that a test can catch the job running. The floor is a little
# larger than the targets ask, so no exact tiling ends the solve at once.
LONG: dict[str, Any] = {
    "name": "offices",
    "boundary": [[0, 0], [16.2, 0], [16.2, 9], [0, 9]],
    "rooms": [{"id": f"office{k}", "type": "office", "min_size": [2, 2], "max_size": [6, 6],
               "target_size": [4.1 - 0.1 * (k % 3), 3.0]} for k in range(12)],
    "options": {"time_limit": 20},
}


@pytest.fixture(scope="module", params=BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def server(backend: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[AnyServer]:
    s = service(backend, tmp_path_factory.mktemp("data")).start()
    yield s
    s.stop()


@pytest.fixture
def client(server: AnyServer) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server.url, timeout=30) as c:
        yield c


def submit(client: httpx.Client, problem: dict[str, Any], **headers: str) -> dict[str, Any]:
    response = client.post("/v1/layouts", json=problem, headers=headers)
    assert response.status_code == 202, response.text
    assert response.headers["location"] == f"/v1/layouts/{response.json()['id']}"
    return response.json()


def wait(client: httpx.Client, job_id: str, timeout: float = 60,
         until: set[str] = TERMINAL) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        job = client.get(f"/v1/layouts/{job_id}").json()
        if job["status"] in until:
            return job
        time.sleep(0.2)
    raise AssertionError(f"job {job_id} still {job['status']} after {timeout} s")


@pytest.mark.slow
def test_submit_follow_the_events_and_fetch_the_result(client: httpx.Client) -> None:
    job = submit(client, SMALL)
    assert job["status"] == "queued"
    events: list[tuple[str, str, dict[str, Any]]] = []
    with client.stream("GET", f"/v1/layouts/{job['id']}/events") as stream:
        assert stream.headers["content-type"].startswith("text/event-stream")
        event_id = kind = ""
        for line in stream.iter_lines():
            if line.startswith("id: "):
                event_id = line[4:]
            elif line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: "):
                events.append((event_id, kind, json.loads(line[6:])))
    kinds = [k for _, k, _ in events]
    assert kinds[0] == "status" and kinds[-1] == "status"
    assert events[-1][2]["status"] == "succeeded"
    assert "progress" in kinds and "incumbent" in kinds
    incumbent = next(data for _, k, data in events if k == "incumbent")
    assert {r["id"] for r in incumbent["layout"]["rooms"]} == {"living", "bed"}
    assert [int(i) for i, _, _ in events] == sorted(int(i) for i, _, _ in events)

    final = client.get(f"/v1/layouts/{job['id']}").json()
    assert final["status"] == "succeeded" and final["termination"] is not None
    assert final["started_at"] and final["finished_at"]
    layout = client.get(f"/v1/layouts/{job['id']}/result").json()
    assert layout["report"]["valid"] and {r["id"] for r in layout["rooms"]} == {"living", "bed"}
    svg = client.get(f"/v1/layouts/{job['id']}/result", params={"format": "svg"})
    assert svg.headers["content-type"].startswith("image/svg+xml") and "<svg" in svg.text
    dxf = client.get(f"/v1/layouts/{job['id']}/result", params={"format": "dxf"})
    assert dxf.headers["content-type"] == "image/vnd.dxf" and "ENTITIES" in dxf.text
    assert "attachment" in dxf.headers["content-disposition"]
    geo = client.get(f"/v1/layouts/{job['id']}/result", params={"format": "geojson"})
    assert geo.headers["content-type"] == "application/geo+json"
    assert geo.json()["type"] == "FeatureCollection"
    ifc = client.get(f"/v1/layouts/{job['id']}/result",
                     params={"format": "ifc", "storey_height": 2.8})
    assert ifc.headers["content-type"] == "application/x-step"
    assert f'filename="{job["id"]}.ifc"' in ifc.headers["content-disposition"]
    model = ifcopenshell.file.from_string(ifc.text)
    assert {s.Name for s in model.by_type("IfcSpace")} == {"living", "bed"}
    assert {ifcopenshell.util.element.get_psets(s)["Qto_SpaceBaseQuantities"]["Height"]
            for s in model.by_type("IfcSpace")} == {2.8}
    too_low = client.get(f"/v1/layouts/{job['id']}/result",
                         params={"format": "ifc", "storey_height": 1})
    assert too_low.status_code == 422
    ncs = client.get(f"/v1/layouts/{job['id']}/result", params={"format": "dxf"})
    assert "A-AREA" in ncs.text and "ROOM_BEDROOM" not in ncs.text
    by_type = client.get(f"/v1/layouts/{job['id']}/result",
                         params={"format": "dxf", "dxf_layers": "room-type"})
    assert "ROOM_BEDROOM" in by_type.text

    # Resuming after the third event replays only what came later.
    third = events[2][0]
    with client.stream("GET", f"/v1/layouts/{job['id']}/events",
                       headers={"Last-Event-ID": third}) as stream:
        ids = [line[4:] for line in stream.iter_lines() if line.startswith("id: ")]
    assert ids == [i for i, _, _ in events[3:]]


@pytest.mark.slow
def test_cancel_stops_the_solve_and_keeps_the_incumbent(client: httpx.Client) -> None:
    job = submit(client, LONG)
    deadline = time.monotonic() + 30
    while client.get(f"/v1/layouts/{job['id']}/result").status_code != 200:
        assert time.monotonic() < deadline, "no incumbent in 30 s"
        time.sleep(0.2)
    running = client.get(f"/v1/layouts/{job['id']}/result").json()
    assert running["report"]["termination"] == "in_progress"
    # Stopped by the cancel: the solve would otherwise end at its 20 s limit, succeeded.
    assert client.post(f"/v1/layouts/{job['id']}/cancel").status_code == 200
    done = wait(client, job["id"], timeout=60)
    assert done["status"] == "canceled" and done["termination"] == "interrupted"
    result = client.get(f"/v1/layouts/{job['id']}/result").json()
    assert result["report"]["valid"] and len(result["rooms"]) == 12
    # Cancelling again changes nothing.
    again = client.post(f"/v1/layouts/{job['id']}/cancel")
    assert again.status_code == 200 and again.json()["status"] == "canceled"


def test_a_result_before_any_layout_is_a_clear_problem(client: httpx.Client) -> None:
    job = submit(client, {**LONG, "name": "not-yet"})
    response = client.get(f"/v1/layouts/{job['id']}/result")
    if response.status_code == 404:  # the usual case: not even an incumbent yet
        assert response.headers["content-type"] == "application/problem+json"
        assert response.json()["title"] == "No layout yet"
    client.post(f"/v1/layouts/{job['id']}/cancel")
    wait(client, job["id"])


def test_delete_removes_a_finished_job_and_refuses_a_running_one(client: httpx.Client) -> None:
    running = submit(client, {**LONG, "name": "still-running"})
    wait(client, running["id"], until={"running"} | TERMINAL)
    refused = client.delete(f"/v1/layouts/{running['id']}")
    assert refused.status_code == 409
    client.post(f"/v1/layouts/{running['id']}/cancel")
    wait(client, running["id"])
    assert client.delete(f"/v1/layouts/{running['id']}").status_code == 204
    assert client.get(f"/v1/layouts/{running['id']}").status_code == 404


def test_idempotency_key_gives_the_same_job_and_refuses_another_body(
    client: httpx.Client,
) -> None:
    first = submit(client, SMALL, **{"Idempotency-Key": "order-17"})
    second = submit(client, SMALL, **{"Idempotency-Key": "order-17"})
    assert first["id"] == second["id"]
    other = client.post("/v1/layouts", json={**SMALL, "name": "else"},
                        headers={"Idempotency-Key": "order-17"})
    assert other.status_code == 409
    assert other.headers["content-type"] == "application/problem+json"
    wait(client, first["id"])


@pytest.mark.slow
def test_listing_pages_through_jobs_newest_first(client: httpx.Client) -> None:
    ids = [submit(client, {**SMALL, "name": f"page-{k}"})["id"] for k in range(3)]
    seen: list[str] = []
    cursor = None
    while True:
        params: dict[str, Any] = {"limit": 2}
        if cursor:
            params["cursor"] = cursor
        page = client.get("/v1/layouts", params=params).json()
        seen += [j["id"] for j in page["data"]]
        cursor = page["next_cursor"]
        if not cursor:
            break
    assert seen.index(ids[2]) < seen.index(ids[1]) < seen.index(ids[0])
    assert len(seen) == len(set(seen))
    queued = client.get("/v1/layouts", params={"status": "succeeded"}).json()["data"]
    assert all(j["status"] == "succeeded" for j in queued)
    for job_id in ids:
        wait(client, job_id)


@pytest.mark.parametrize(
    ("body", "status"),
    [
        (b"{not json", 400),
        (b"[]", 422),
        (b'{"boundary": "square", "rooms": []}', 422),
        (json.dumps({**SMALL, "rooms": [{"id": "a", "min_size": ["wide", 2]}]}).encode(), 422),
        (json.dumps({**SMALL, "boundary": [[0, 0], [1e300, 0], [1e300, 4], [0, 4]]}).encode(),
         422),
        (json.dumps({**SMALL, "adjacency": [{"a": "living", "b": "ghost"}]}).encode(), 422),
        (json.dumps({**SMALL, "options": {"time_limit": 10_000}}).encode(), 422),
        (b"\xff\xfe\x00", 400),
    ],
    ids=["broken", "array", "wrong-type", "string-size", "huge", "unknown-room",
         "time-limit", "not-utf8"],
)
def test_bad_bodies_get_a_problem_document_never_a_5xx(
    client: httpx.Client, body: bytes, status: int
) -> None:
    response = client.post("/v1/layouts", content=body,
                           headers={"content-type": "application/json"})
    assert response.status_code == status
    assert response.headers["content-type"] == "application/problem+json"
    problem = response.json()
    assert problem["status"] == status and problem["title"] and problem["detail"]
    if status == 422 and problem.get("errors"):
        assert all(e["field"] for e in problem["errors"])


def test_unknown_room_ids_are_named_in_the_problem_document(client: httpx.Client) -> None:
    body = {**SMALL, "adjacency": [{"a": "living", "b": "ghost"}]}
    problem = client.post("/v1/layouts", json=body).json()
    assert [e["field"] for e in problem["errors"]] == ["adjacency.0.b"]


def test_a_ten_megabyte_body_is_refused_with_413(client: httpx.Client) -> None:
    body = b'{"name": "' + b"x" * (10 << 20) + b'"}'
    response = client.post("/v1/layouts", content=body,
                           headers={"content-type": "application/json"})
    assert response.status_code == 413
    assert response.headers["content-type"] == "application/problem+json"


def test_unknown_routes_and_jobs_are_problem_documents(client: httpx.Client) -> None:
    for path in ("/nowhere", "/v1/layouts/00000000-0000-0000-0000-000000000000",
                 "/v1/layouts/not-a-uuid"):
        response = client.get(path)
        assert 400 <= response.status_code < 500
        assert response.headers["content-type"] == "application/problem+json"


def test_validate_reports_schema_errors_and_cheap_impossibilities(client: httpx.Client) -> None:
    assert client.post("/v1/validate", json=SMALL).json() == {
        "valid": True, "errors": [], "findings": [], "problem": SMALL}
    bad = client.post("/v1/validate", json={**SMALL, "rooms": [{"id": "a", "min_size": [3, 2],
                                                                "max_size": [2, 2]}]}).json()
    assert not bad["valid"] and bad["errors"][0]["field"] == "rooms.0.min_size.0"
    crowded = {**SMALL, "adjacency": [],
               "rooms": [{"id": k, "min_size": [4, 4]} for k in "ab"]}
    verdict = client.post("/v1/validate", json=crowded).json()
    assert not verdict["valid"] and "minimum sizes need" in verdict["findings"][0]


def test_openapi_and_docs_are_served_with_examples(client: httpx.Client) -> None:
    schema = client.get("/openapi.json").json()
    body = schema["paths"]["/v1/layouts"]["post"]["requestBody"]["content"]["application/json"]
    assert body["schema"] == {"anyOf": [{"$ref": "#/components/schemas/Problem"},
                                        {"$ref": "#/components/schemas/TemplatedProblem"}]}
    assert set(body["examples"]) == {"plain", "templated"}
    assert {"Room", "RoomSketch"} <= set(schema["components"]["schemas"])
    assert client.get("/docs").status_code == 200


CONCURRENT = 16


@pytest.mark.slow
def test_concurrent_submissions_all_finish(client: httpx.Client) -> None:
    # Eight times as many posts at once as workers (2); each job runs in a process of
    # its own, so every one more costs the suite about 0.4 s.
    ids: list[str] = []
    lock = threading.Lock()

    def post(k: int) -> None:
        with httpx.Client(base_url=str(client.base_url), timeout=30) as own:
            job = submit(own, {**SMALL, "name": f"burst-{k}", "options": {"time_limit": 0.3}})
        with lock:
            ids.append(job["id"])

    threads = [threading.Thread(target=post, args=(k,)) for k in range(CONCURRENT)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(set(ids)) == CONCURRENT
    finished = [wait(client, job_id, timeout=120) for job_id in ids]
    assert all(job["status"] == "succeeded" for job in finished)


@pytest.mark.slow
def test_a_killed_service_resumes_its_jobs_after_a_restart(backend: str, tmp_path: Path) -> None:
    # Distributed: every process dies; the job's lease expires and it runs again.
    first = service(backend, tmp_path).start()
    with httpx.Client(base_url=first.url, timeout=30) as c:
        job = submit(c, {**LONG, "options": {"time_limit": 4}})
        wait(c, job["id"], until={"running"})
    first.kill()
    second = service(backend, tmp_path).start()
    try:
        with httpx.Client(base_url=second.url, timeout=30) as c:
            done = wait(c, job["id"], timeout=60)
            assert done["status"] == "succeeded"
            assert done["attempts"] == 2
            assert c.get(f"/v1/layouts/{job['id']}/result").json()["report"]["valid"]
    finally:
        second.stop()


@pytest.mark.slow
def test_api_keys_guard_every_request_and_hide_other_keys_jobs(
    backend: str, tmp_path: Path
) -> None:
    s = service(backend, tmp_path, FLOORPLAN_API_KEYS="alpha, beta").start()
    try:
        with httpx.Client(base_url=s.url, timeout=30) as c:
            refused = c.post("/v1/layouts", json=SMALL)
            assert refused.status_code == 401
            assert refused.headers["content-type"] == "application/problem+json"
            alpha = {"Authorization": "Bearer alpha"}
            job = c.post("/v1/layouts", json=SMALL, headers=alpha).json()
            assert c.get(f"/v1/layouts/{job['id']}", headers=alpha).status_code == 200
            assert c.get(f"/v1/layouts/{job['id']}", headers={"X-API-Key": "beta"}) \
                .status_code == 404
            assert c.get("/v1/layouts", headers={"X-API-Key": "beta"}).json()["data"] == []
            assert c.get(f"/v1/layouts/{job['id']}",
                         headers={"Authorization": "Bearer gamma"}).status_code == 401
            wait_with = httpx.Client(base_url=s.url, timeout=30, headers=alpha)
            with wait_with:
                wait(wait_with, job["id"])
    finally:
        s.stop()


@pytest.mark.slow
def test_a_full_queue_answers_429_with_retry_after(backend: str, tmp_path: Path) -> None:
    s = service(backend, tmp_path, FLOORPLAN_QUEUE_LIMIT="1", WORKERS="1").start()
    try:
        with httpx.Client(base_url=s.url, timeout=30) as c:
            busy = submit(c, {**LONG, "options": {"time_limit": 30}})
            wait(c, busy["id"], until={"running"})
            waiting = submit(c, SMALL)
            full = c.post("/v1/layouts", json=SMALL)
            assert full.status_code == 429
            assert int(full.headers["retry-after"]) > 0
            assert full.headers["content-type"] == "application/problem+json"
            c.post(f"/v1/layouts/{busy['id']}/cancel")
            wait(c, waiting["id"])
    finally:
        s.stop()


@pytest.mark.slow
def test_a_stopped_service_hands_running_jobs_back_without_counting_an_attempt(
    backend: str, tmp_path: Path,
) -> None:
    first = service(backend, tmp_path).start()
    with httpx.Client(base_url=first.url, timeout=30) as c:
        job = submit(c, {**LONG, "options": {"time_limit": 4}})
        wait(c, job["id"], until={"running"})
    first.stop()  # SIGTERM: a graceful stop
    second = service(backend, tmp_path).start()
    try:
        with httpx.Client(base_url=second.url, timeout=30) as c:
            done = wait(c, job["id"], timeout=60)
            assert done["status"] == "succeeded" and done["attempts"] == 1
    finally:
        second.stop()


def solve_processes(parent: int) -> list[int]:
    """The solve children of `parent` (spawned: their command line runs spawn_main)."""
    # -ww: without a terminal ps cuts args at 80 columns, and venv paths are long.
    out = subprocess.run(["ps", "-ww", "-o", "pid=,args=", "--ppid", str(parent)],
                         capture_output=True, text=True).stdout
    return [int(line.split()[0]) for line in out.splitlines() if "spawn_main" in line]


@pytest.mark.slow
def test_a_crashed_solve_fails_its_own_job_and_the_service_carries_on(
    backend: str, tmp_path: Path
) -> None:
    s = service(backend, tmp_path).start()
    try:
        with httpx.Client(base_url=s.url, timeout=30) as c:
            doomed = submit(c, {**LONG, "options": {"time_limit": 30}})
            wait(c, doomed["id"], until={"running"})
            deadline = time.monotonic() + 60
            while not (children := [pid for parent in s.solver_parents()
                                    for pid in solve_processes(parent)]):
                assert time.monotonic() < deadline, "no solve process found"
                time.sleep(0.1)
            for pid in children:
                os.kill(pid, signal.SIGKILL)  # as a segfault or the OOM killer would
            failed = wait(c, doomed["id"], timeout=30)
            assert failed["status"] == "failed"
            assert failed["error"]["code"] == "worker_died"
            assert "died" in failed["error"]["message"]
            assert c.get("/readyz").status_code == 200
            assert wait(c, submit(c, SMALL)["id"])["status"] == "succeeded"
    finally:
        s.stop()


# Templates (paper Sec. 5.4): room types alone make a problem.

TEMPLATED: dict[str, Any] = {
    "name": "templated-flat",
    "boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
    "entrance": [2, 0],
    "template": "residential",
    "rooms": ["foyer", "living", "kitchen", {"type": "bedroom", "boundary": ["north"]},
              "bedroom", "bathroom"],
    "options": {"time_limit": 3, "seed": 0},
}


@pytest.mark.slow
def test_a_templated_problem_is_queued_and_solved_to_a_valid_layout(
    client: httpx.Client,
) -> None:
    job = submit(client, TEMPLATED)
    assert wait(client, job["id"])["status"] == "succeeded"
    layout = client.get(f"/v1/layouts/{job['id']}/result").json()
    assert {r["id"] for r in layout["rooms"]} == {
        "foyer", "living", "kitchen", "bedroom-1", "bedroom-2", "bathroom"}
    assert layout["report"]["valid"]
    # The report checks what the template filled in, and what the user stated.
    checks = {(c["kind"], tuple(c["rooms"])) for c in layout["report"]["constraints"]}
    assert ("size", ("bedroom-2",)) in checks and ("boundary", ("bedroom-1",)) in checks
    assert client.get(f"/v1/layouts/{job['id']}/result?format=svg").status_code == 200


def test_validate_returns_the_expanded_problem_ready_to_edit_and_resend(
    client: httpx.Client,
) -> None:
    verdict = client.post("/v1/validate", json=TEMPLATED).json()
    assert verdict["valid"] and verdict["errors"] == [] and verdict["findings"] == []
    expanded = verdict["problem"]
    assert "template" not in expanded and "openings" not in expanded
    rooms = {r["id"]: r for r in expanded["rooms"]}
    assert rooms["bedroom-1"]["boundary"] == ["north"]  # stated, kept
    assert rooms["bedroom-2"]["boundary"] == ["north", "south", "east", "west"]
    assert all("target_size" in r for r in rooms.values()) and expanded["adjacency"]
    again = client.post("/v1/validate", json=expanded).json()
    assert again["valid"] and again["problem"] == expanded


def test_unknown_templates_and_room_types_are_422_naming_the_field(
    client: httpx.Client,
) -> None:
    response = client.post("/v1/layouts", json={**TEMPLATED, "template": "castle"})
    assert response.status_code == 422
    assert [e["field"] for e in response.json()["errors"]] == ["template"]
    response = client.post("/v1/layouts", json={**TEMPLATED, "rooms": ["living", "moat"]})
    assert response.status_code == 422
    error = response.json()["errors"][0]
    assert error["field"] == "rooms.1" and "moat" in error["message"]
    crowded = client.post("/v1/validate", json={**TEMPLATED, "rooms": ["bedroom"] * 14}).json()
    assert not crowded["valid"] and crowded["errors"][0]["field"] == "rooms"
    assert "problem" not in crowded
