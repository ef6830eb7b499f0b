"""The security review (docs/security.md), requests from outside: cross-site posts,
DNS rebinding onto a service on loopback, and per-key limits that starve nothing;
each finding replayed against a real server process on loopback."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from tests.servers import Server
from tests.service.test_service import SMALL, wait

KEY = {"Authorization": "Bearer alpha"}
#: One solve at a time and no sub-domain pool: these tests solve little.
QUIET = {"WORKERS": "1", "FLOORPLAN_SUBDOMAIN_PROCESSES": "1"}



# Cross-site requests and DNS rebinding onto a service on loopback.


@pytest.fixture(scope="module")
def open_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """No keys (the default), on loopback with the default allowed hosts."""
    server = Server(tmp_path_factory.mktemp("open"), **QUIET).start()
    yield server
    server.stop()


@pytest.mark.slow
@pytest.mark.parametrize("path", ["/v1/layouts", "/v1/validate"])
@pytest.mark.parametrize("content_type", [
    "text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x",
    None, "application/jsonp", "text/json",
])
def test_a_body_not_sent_as_json_is_a_415(open_server: Server, path: str,
                                          content_type: str | None) -> None:
    # What a web page of another site may post to a local service without a preflight.
    headers = {"Content-Type": content_type} if content_type else {}
    with httpx.Client(base_url=open_server.url, timeout=30) as client:
        response = client.post(path, content=json.dumps(SMALL).encode(), headers=headers)
        assert response.status_code == 415, response.text
        assert response.headers["content-type"] == "application/problem+json"
        assert response.json()["type"].endswith("/unsupported-media-type")
        assert response.headers["accept-post"] == "application/json"
        assert client.get("/v1/layouts").json()["data"] == []  # nothing queued


@pytest.mark.slow
def test_json_with_a_charset_and_the_python_client_and_cli_still_get_through(
        open_server: Server, tmp_path: Path) -> None:
    import subprocess
    import sys

    from floorplan_client import Client

    with httpx.Client(base_url=open_server.url, timeout=30) as client:
        response = client.post("/v1/validate", content=json.dumps(SMALL).encode(),
                               headers={"Content-Type": "Application/JSON; charset=utf-8"})
        assert response.status_code == 200 and response.json()["valid"]
    with Client(open_server.url) as sdk:
        assert sdk.validate(SMALL).valid
        job = sdk.submit(SMALL)
        job.cancel()
    problem = tmp_path / "small.json"
    problem.write_text(json.dumps(SMALL))
    done = subprocess.run([sys.executable, "-m", "floorplan.service", "submit", str(problem),
                           "--server", open_server.url, "-q"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    with httpx.Client(base_url=open_server.url, timeout=60) as client:
        for listed in client.get("/v1/layouts").json()["data"]:
            client.post(f"/v1/layouts/{listed['id']}/cancel")
            wait(client, listed["id"])


@pytest.mark.slow
@pytest.mark.parametrize("host", ["evil.example", "evil.example:8000", "localhost.evil.example",
                                  "127.0.0.1.nip.io", "0.0.0.0"])
def test_a_service_on_loopback_answers_only_to_loopback_names(open_server: Server,
                                                              host: str) -> None:
    # DNS rebinding: a name the attacker controls, pointed at 127.0.0.1.
    for path in ("/healthz", "/v1/layouts", "/"):
        response = httpx.get(open_server.url + path, headers={"Host": host}, timeout=30)
        assert response.status_code == 400, response.text
        assert response.headers["content-type"] == "application/problem+json"
        assert response.json()["type"].endswith("/untrusted-host")
    posted = httpx.post(open_server.url + "/v1/layouts", json=SMALL, headers={"Host": host},
                        timeout=30)
    assert posted.status_code == 400


@pytest.mark.slow
@pytest.mark.parametrize("host", ["localhost", "LOCALHOST:1234", "127.0.0.1", "[::1]:8000"])
def test_loopback_names_are_answered(open_server: Server, host: str) -> None:
    response = httpx.get(open_server.url + "/healthz", headers={"Host": host}, timeout=30)
    assert response.status_code == 200, response.text


@pytest.mark.slow
def test_the_allowed_hosts_are_a_setting(tmp_path: Path) -> None:
    server = Server(tmp_path, FLOORPLAN_ALLOWED_HOSTS="plans.example, *.plans.example",
                    **QUIET)
    # The start waits for /readyz on 127.0.0.1, no longer an allowed name: ask by hand.
    server.env["FLOORPLAN_ALLOWED_HOSTS"] += ",127.0.0.1"
    server.start()
    try:
        for host, status in (("plans.example", 200), ("eu.plans.example:443", 200),
                             ("localhost", 400), ("evil.example", 400)):
            response = httpx.get(server.url + "/healthz", headers={"Host": host}, timeout=30)
            assert response.status_code == status, (host, response.text)
    finally:
        server.stop()



# Per-key fairness, and explain calls that starve nothing.

FAIR_KEYS = ["alpha", "beta", "gamma", "delta"]


def bearer(key: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"}


@pytest.fixture(scope="module")
def fair(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    server = Server(tmp_path_factory.mktemp("fair"), FLOORPLAN_API_KEYS=",".join(FAIR_KEYS),
                    FLOORPLAN_MAX_JOBS_PER_KEY="2", FLOORPLAN_QUEUE_LIMIT="4",
                    FLOORPLAN_MAX_STREAMS_PER_KEY="2", FLOORPLAN_MAX_STREAMS="3",
                    FLOORPLAN_MAX_EXPLAINS_PER_KEY="1", FLOORPLAN_EXPLAIN_PROCESSES="2",
                    **QUIET).start()
    yield server
    server.stop()


def assert_too_many(response: httpx.Response, variable: str) -> None:
    assert response.status_code == 429, response.text
    assert response.headers["content-type"] == "application/problem+json"
    assert int(response.headers["retry-after"]) > 0
    problem = response.json()
    assert problem["type"].startswith("/docs/problems/too-many-")
    assert variable in problem["detail"]


@pytest.mark.slow
def test_one_key_filling_its_quota_leaves_room_for_the_next(fair: Server) -> None:
    from tests.service.test_service import LONG

    with httpx.Client(base_url=fair.url, timeout=30) as client:
        jobs = [client.post("/v1/layouts", json=LONG, headers=bearer("alpha"))
                for _ in range(2)]
        assert [j.status_code for j in jobs] == [202, 202]
        assert_too_many(client.post("/v1/layouts", json=LONG, headers=bearer("alpha")),
                        "FLOORPLAN_MAX_JOBS_PER_KEY")
        other = client.post("/v1/layouts", json=SMALL, headers=bearer("beta"))
        assert other.status_code == 202, other.text
        # A finished job no longer counts.
        client.post(f"/v1/layouts/{jobs[0].json()['id']}/cancel", headers=bearer("alpha"))
        for job, key in ((jobs[0], "alpha"), (jobs[1], "alpha"), (other, "beta")):
            wait_keyed(client, job.json()["id"], key, cancel=True)
        again = client.post("/v1/layouts", json=SMALL, headers=bearer("alpha"))
        assert again.status_code == 202
        wait_keyed(client, again.json()["id"], "alpha", cancel=True)


def wait_keyed(client: httpx.Client, job_id: str, key: str, cancel: bool = False) -> None:
    if cancel:
        client.post(f"/v1/layouts/{job_id}/cancel", headers=bearer(key))
    deadline = time.monotonic() + 60
    while client.get(f"/v1/layouts/{job_id}", headers=bearer(key)).json()["status"] in (
            "queued", "running"):
        assert time.monotonic() < deadline
        time.sleep(0.2)


@pytest.mark.slow
def test_open_event_streams_are_limited_per_key_and_in_all(fair: Server) -> None:
    from tests.service.test_service import LONG

    with httpx.Client(base_url=fair.url, timeout=30) as client:
        mine = client.post("/v1/layouts", json=LONG, headers=bearer("alpha")).json()["id"]
        theirs = client.post("/v1/layouts", json=LONG, headers=bearer("beta")).json()["id"]
        try:
            def open_stream(job_id: str, key: str) -> Any:
                return client.stream("GET", f"/v1/layouts/{job_id}/events",
                                     headers=bearer(key))

            with open_stream(mine, "alpha") as first, open_stream(mine, "alpha") as second:
                assert first.status_code == second.status_code == 200
                refused = client.get(f"/v1/layouts/{mine}/events", headers=bearer("alpha"))
                assert_too_many(refused, "FLOORPLAN_MAX_STREAMS_PER_KEY")
                with open_stream(theirs, "beta") as third:
                    assert third.status_code == 200  # another key's first stream
                    assert_too_many(client.get(f"/v1/layouts/{theirs}/events",
                                               headers=bearer("beta")), "FLOORPLAN_MAX_STREAMS")
            # Closed streams are given back.
            deadline = time.monotonic() + 60
            while True:
                with open_stream(mine, "alpha") as s1, open_stream(mine, "alpha") as s2, \
                        open_stream(theirs, "beta") as s3:
                    if [s.status_code for s in (s1, s2, s3)] == [200] * 3:
                        break
                assert time.monotonic() < deadline, "closed streams still counted"
                time.sleep(0.5)
        finally:
            wait_keyed(client, mine, "alpha", cancel=True)
            wait_keyed(client, theirs, "beta", cancel=True)


#: Infeasible by packing (12 rooms of at least 3.3 x 3.3 m in 16 x 9 m): explain's
#: conflict search runs for seconds.
TIGHT: dict[str, Any] = {
    "boundary": [[0, 0], [16, 0], [16, 9], [0, 9]],
    "rooms": [{"id": f"o{k}", "min_size": [3.3, 3.3], "max_size": [6, 6]} for k in range(12)],
}


@pytest.mark.slow
def test_explain_calls_are_limited_per_key_and_starve_nothing(fair: Server) -> None:
    answers: dict[str, httpx.Response] = {}

    def explain(key: str) -> None:
        answers[key] = httpx.post(f"{fair.url}/v1/validate", json=TIGHT, headers=bearer(key),
                                  params={"explain": "true", "time_limit": "6"}, timeout=60)

    with httpx.Client(base_url=fair.url, timeout=30) as client:
        job = client.post("/v1/layouts", json=SMALL, headers=bearer("alpha")).json()["id"]
        wait_keyed(client, job, "alpha")
        calls = [threading.Thread(target=explain, args=(key,)) for key in FAIR_KEYS]
        for call in calls:
            call.start()
        # A second call of alpha's while its first is in flight: on a fast machine an
        # explanation of TIGHT takes about a second, so at 0.5 s the thread's call is
        # being explained and this one is refused; on a busy one the thread's request
        # may reach the server after this one, which then holds the slot, and the
        # thread's is refused. Either way one of the two is a 429.
        time.sleep(0.5)
        fifth = client.post("/v1/validate", json=TIGHT, headers=bearer("alpha"),
                            params={"explain": "true"})
        slowest = {"healthz": 0.0, "validate": 0.0, "events": 0.0}
        rounds = 0
        while any(call.is_alive() for call in calls):
            rounds += 1
            for name, call in (
                    ("healthz", lambda: client.get("/healthz")),
                    ("validate", lambda: client.post("/v1/validate", json=SMALL,
                                                     headers=bearer("beta"))),
                    ("events", lambda: client.get(f"/v1/layouts/{job}/events",
                                                  headers=bearer("alpha")))):
                started = time.monotonic()
                assert call().status_code == 200
                slowest[name] = max(slowest[name], time.monotonic() - started)
            time.sleep(0.1)
        for call in calls:
            call.join()
    pair = [answers["alpha"], fifth]
    assert sorted(r.status_code for r in pair) == [200, 429], [r.text for r in pair]
    assert_too_many(next(r for r in pair if r.status_code == 429),
                    "FLOORPLAN_MAX_EXPLAINS_PER_KEY")
    explained = [answers[key] for key in FAIR_KEYS if answers[key].status_code == 200]
    assert [answers[key].status_code for key in FAIR_KEYS[1:]] == [200] * 3
    # Infeasible: proved so, or left open when the time ran out; never feasible.
    assert all(r.json()["feasible"] is not True for r in explained)
    # Nothing waited for an explanation (in a process of its own): every call was
    # answered in less than half the time the quickest explanation took, and calls were
    # answered all along. Against the explanations, not seconds: both grow on a busy
    # machine (0.2 s for /healthz and 1 s for the others on an idle one).
    quickest = min(r.elapsed.total_seconds() for r in explained)
    assert max(slowest.values()) < quickest / 2, (slowest, quickest)
    assert rounds >= 3, rounds
