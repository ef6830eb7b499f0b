"""The limits of POST /v1/batches under attack, against real service processes on
loopback in both modes (embedded on SQLite, an API node with Celery workers on
PostgreSQL and Redis): concurrent batches cannot pass the per-key or queue limits
together, a brief cannot multiply stored bytes, and cursors out of range are a 4xx."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from tests.servers import BACKENDS, AnyServer, service
from tests.service.test_service import SMALL

TINY = {**SMALL, "options": {}}
KEYS = ["alpha", "beta", "gamma", "delta"]
#: The review's race: four batches of 300 at once on a key of 400 jobs, queue of 1,000.
LIMITS = {"FLOORPLAN_MAX_JOBS_PER_KEY": "400", "FLOORPLAN_QUEUE_LIMIT": "1000",
          "FLOORPLAN_API_KEYS": ",".join(KEYS), "WORKERS": "1",
          "FLOORPLAN_SUBDOMAIN_PROCESSES": "1"}


def bearer(key: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"} if key else {}


@pytest.fixture(scope="module", params=BACKENDS)
def server(request: pytest.FixtureRequest,
           tmp_path_factory: pytest.TempPathFactory) -> Iterator[AnyServer]:
    s = service(str(request.param), tmp_path_factory.mktemp("limits"), **LIMITS).start()
    yield s
    s.stop()


def at_once(posts: list[tuple[str, dict[str, Any]]], url: str) -> list[httpx.Response]:
    """The posts (key, body) sent together, each from its own thread and connection,
    released by one barrier."""
    barrier = threading.Barrier(len(posts))
    answers: list[httpx.Response | None] = [None] * len(posts)

    def post(k: int) -> None:
        key, body = posts[k]
        with httpx.Client(base_url=url, timeout=120) as client:
            barrier.wait()
            answers[k] = client.post("/v1/batches", json=body, headers=bearer(key))

    threads = [threading.Thread(target=post, args=(k,)) for k in range(len(posts))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert all(a is not None for a in answers)
    return [a for a in answers if a is not None]


def unfinished(client: httpx.Client, key: str) -> int:
    """The key's queued and running jobs, as its job list shows them."""
    total = 0
    for status in ("queued", "running"):
        cursor = None
        while True:
            params: dict[str, Any] = {"status": status, "limit": 200}
            if cursor:
                params["cursor"] = cursor
            page = client.get("/v1/layouts", params=params, headers=bearer(key)).json()
            total += len(page["data"])
            cursor = page.get("next_cursor")
            if not cursor:
                break
    return total


def cancel_all(client: httpx.Client, accepted: list[tuple[str, str]]) -> None:
    """Cancel the batches (key, id) and wait until none of their jobs is left running,
    so that the next test starts from an empty queue."""
    for key, batch_id in accepted:
        client.post(f"/v1/batches/{batch_id}/cancel", headers=bearer(key))
    deadline = time.monotonic() + 120
    for key, batch_id in accepted:
        while client.get(f"/v1/batches/{batch_id}", headers=bearer(key)).json()["status"] in (
                "queued", "running"):
            assert time.monotonic() < deadline
            time.sleep(0.2)


def test_four_concurrent_batches_on_one_key_keep_to_its_limit(server: AnyServer) -> None:
    body = {"problem": TINY, "count": 300, "time_limit": 5}
    answers = at_once([("alpha", body)] * 4, server.url)
    codes = sorted(a.status_code for a in answers)
    assert codes == [202, 429, 429, 429], [a.text[:200] for a in answers]
    for refused in (a for a in answers if a.status_code == 429):
        assert "FLOORPLAN_MAX_JOBS_PER_KEY" in refused.json()["detail"]
    with httpx.Client(base_url=server.url, timeout=60) as client:
        assert unfinished(client, "alpha") <= 400
        cancel_all(client, [("alpha", a.json()["id"]) for a in answers if a.status_code == 202])


def test_concurrent_batches_of_four_keys_keep_to_the_queue_limit(server: AnyServer) -> None:
    body = {"problem": TINY, "count": 300, "time_limit": 5}
    answers = at_once([(key, body) for key in KEYS], server.url)
    accepted = [(key, a.json()["id"]) for key, a in zip(KEYS, answers, strict=True)
                if a.status_code == 202]
    refused = [a for a in answers if a.status_code == 429]
    # 3 x 300 fit the queue of 1,000, a fourth does not.
    assert len(accepted) == 3 and len(refused) == 1, [a.text[:200] for a in answers]
    assert "FLOORPLAN_QUEUE_LIMIT" in refused[0].json()["detail"]
    with httpx.Client(base_url=server.url, timeout=60) as client:
        assert sum(unfinished(client, key) for key in KEYS) <= 1000
        cancel_all(client, accepted)


def test_a_cursor_out_of_range_is_a_422_not_a_500(server: AnyServer) -> None:
    with httpx.Client(base_url=server.url, timeout=60) as client:
        made = client.post("/v1/batches", json={"problem": TINY, "count": 1},
                           headers=bearer("beta"))
        assert made.status_code == 202, made.text
        batch = made.json()["id"]
        for after in ("99999999999999999999", "10000", "-2", "1e3"):
            bad = client.get(f"/v1/batches/{batch}/results", params={"after": after},
                             headers=bearer("beta"))
            assert bad.status_code == 422, (after, bad.text)
            assert bad.headers["content-type"] == "application/problem+json"
            assert bad.json()["errors"][0]["field"] == "query.after"
        for limit in ("99999999999999999999", "0"):
            bad = client.get(f"/v1/batches/{batch}/results", params={"limit": limit},
                             headers=bearer("beta"))
            assert bad.status_code == 422, (limit, bad.text)
        ok = client.get(f"/v1/batches/{batch}/results", params={"after": 9999},
                        headers=bearer("beta"))
        assert ok.status_code == 200
        cancel_all(client, [("beta", batch)])


def test_a_brief_cannot_carry_a_payload_into_every_layout(server: AnyServer) -> None:
    """The review stored a 2 MB brief (obstacle labels of 40 KB) 200 times: 830 MB of
    store. Labels are bounded by the contract, and the brief by the body limit."""
    labelled = {**TINY, "obstacles": [{"x": 0, "y": 0, "width": 0.5, "depth": 0.5,
                                       "label": "x" * 40_000}]}
    with httpx.Client(base_url=server.url, timeout=60) as client:
        long_label = client.post("/v1/batches", json={"problem": labelled, "count": 200},
                                 headers=bearer("gamma"))
        assert long_label.status_code == 422, long_label.text
        assert [e["field"] for e in long_label.json()["errors"]] == [
            "problem.obstacles.0.label"]
        huge = {**TINY, "name": "n", "notes": "x" * (2 << 20)}
        too_big = client.post("/v1/batches", json={"problem": huge, "count": 200},
                              headers=bearer("gamma"))
        assert too_big.status_code == 413, too_big.text
        assert unfinished(client, "gamma") == 0


@pytest.mark.slow
def test_a_batch_s_stored_bytes_are_bounded(tmp_path: Path) -> None:
    s = service("embedded", tmp_path, FLOORPLAN_MAX_BATCH_BYTES="65536", WORKERS="1",
                FLOORPLAN_SUBDOMAIN_PROCESSES="1").start()
    try:
        with httpx.Client(base_url=s.url, timeout=60) as client:
            over = client.post("/v1/batches", json={"problem": TINY, "count": 200})
            assert over.status_code == 413, over.text
            assert "FLOORPLAN_MAX_BATCH_BYTES" in over.json()["detail"]
            assert over.json()["type"].endswith("/batch-too-large")
            fits = client.post("/v1/batches", json={"problem": TINY, "count": 2})
            assert fits.status_code == 202, fits.text
            cancel_all(client, [("", fits.json()["id"])])
    finally:
        s.stop()


@pytest.mark.slow
def test_a_key_s_stored_bytes_count_canceled_jobs_until_deleted(tmp_path: Path) -> None:
    """Canceling a batch freed nothing of the store (the review's 906 MB stayed): a
    key's jobs, canceled ones included, count against its storage quota until they
    are deleted."""
    s = service("embedded", tmp_path, FLOORPLAN_MAX_STORED_BYTES_PER_KEY="40000",
                WORKERS="1", FLOORPLAN_SUBDOMAIN_PROCESSES="1").start()
    body = {"problem": TINY, "count": 20}  # about 27 KB of problems
    try:
        with httpx.Client(base_url=s.url, timeout=60) as client:
            first = client.post("/v1/batches", json=body)
            assert first.status_code == 202, first.text
            cancel_all(client, [("", first.json()["id"])])
            refused = client.post("/v1/batches", json=body)
            assert refused.status_code == 429, refused.text
            assert refused.json()["type"].endswith("/storage-quota")
            assert "FLOORPLAN_MAX_STORED_BYTES_PER_KEY" in refused.json()["detail"]
            lines = client.get(f"/v1/batches/{first.json()['id']}/results",
                               params={"layouts": "false"}).text.splitlines()
            assert len(lines) == 20
            for line in lines:
                job_id = json.loads(line)["job_id"]
                assert client.delete(f"/v1/layouts/{job_id}").status_code == 204
            again = client.post("/v1/batches", json=body)
            assert again.status_code == 202, again.text
            cancel_all(client, [("", again.json()["id"])])
    finally:
        s.stop()
