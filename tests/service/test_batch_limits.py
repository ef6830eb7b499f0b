"""The limits of POST /v1/batches under attack, against real service processes on
loopback in both modes (embedded on SQLite, an API node with Celery workers on
PostgreSQL and Redis): concurrent batches cannot pass the per-key or queue limits
together, a brief cannot multiply stored bytes, and cursors out of range are a 4xx."""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest
from sqlalchemy import select

from floorplan.models import Problem
from floorplan.service.batch import layout_problem
from floorplan.service.store import JobStore
from floorplan.service.tables import jobs
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
def test_a_key_s_stored_bytes_count_canceled_jobs_until_deleted(tmp_path: Path) -> None:
    """Canceling a batch freed nothing of the store (the review's 906 MB stayed): a
    key's jobs, canceled ones included, count against its storage quota until they
    are deleted; a batch's brief, stored once, goes with its last job."""
    brief = large_brief()
    size = len(json.dumps(brief, separators=(",", ":")).encode())
    s = service("embedded", tmp_path, FLOORPLAN_MAX_STORED_BYTES_PER_KEY=str(size * 3 // 2),
                WORKERS="1", FLOORPLAN_SUBDOMAIN_PROCESSES="1").start()
    body = {"problem": brief, "count": 20}
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

def large_brief(rooms: int = 300) -> dict[str, Any]:
    """A valid brief of about 180 KB: long room ids, two adjacencies a room."""
    ids = [f"room-{k:04d}-" + "x" * 89 for k in range(rooms)]
    return {"name": "large", "boundary": [[0, 0], [200, 0], [200, 150], [0, 150]],
            "rooms": [{"id": i, "min_size": [2, 2], "max_size": [20, 20]} for i in ids],
            "adjacency": [{"a": ids[k], "b": ids[(k + d) % rooms]}
                          for k in range(rooms) for d in (1, 2)]}


def stored(database: Path, batch_id: str) -> tuple[int, int, int]:
    """What the store holds, read from its file as any SQLite reader would: the bytes
    in use (pages less free pages), the batch's problem bytes (its jobs' problems and
    its brief) and its jobs' layout bytes (results, incumbents)."""
    conn = sqlite3.connect(f"file:{database}?mode=ro", uri=True)
    try:
        pages, free, size = (conn.execute(f"PRAGMA {name}").fetchone()[0]
                             for name in ("page_count", "freelist_count", "page_size"))
        problems, layouts = conn.execute(
            "SELECT COALESCE(SUM(LENGTH(CAST(problem AS BLOB))), 0), "
            "COALESCE(SUM(COALESCE(LENGTH(CAST(result AS BLOB)), 0) "
            "+ COALESCE(LENGTH(CAST(incumbent AS BLOB)), 0)), 0) "
            "FROM jobs WHERE batch_id = ?", (batch_id,)).fetchone()
        brief = conn.execute("SELECT COALESCE((SELECT LENGTH(CAST(brief AS BLOB)) FROM "
                             "batches WHERE id = ?), 0)", (batch_id,)).fetchone()[0]
    finally:
        conn.close()
    return (pages - free) * size, problems + brief, layouts


@pytest.mark.slow
def test_a_batch_stores_its_brief_once_whatever_its_count(tmp_path: Path) -> None:
    """The review's 2 MB brief x 200 grew the store by 830 MB: each layout stored the
    brief again. Now a batch of 200 stores the brief once, as a batch of 1 does; its
    layouts add rows of their own, not briefs (measured in the server's SQLite file)."""
    brief = large_brief()
    size = len(json.dumps(brief, separators=(",", ":")).encode())
    s = service("embedded", tmp_path, WORKERS="1", FLOORPLAN_SUBDOMAIN_PROCESSES="1",
                FLOORPLAN_MAX_BATCH_BYTES=str(size + 10_000)).start()
    database = tmp_path / "jobs.sqlite3"
    try:
        with httpx.Client(base_url=s.url, timeout=120) as client:
            # FLOORPLAN_MAX_BATCH_BYTES bounds the brief as stored, not count times it.
            over = client.post("/v1/batches", json={"problem": large_brief(340), "count": 1})
            assert over.status_code == 413, over.text
            assert "FLOORPLAN_MAX_BATCH_BYTES" in over.json()["detail"]
            assert over.json()["type"].endswith("/batch-too-large")
            grown = {}
            for count in (1, 200):
                used_before = stored(database, "")[0]
                made = client.post("/v1/batches", json={"problem": brief, "count": count})
                assert made.status_code == 202, made.text
                batch = made.json()["id"]
                cancel_all(client, [("", batch)])
                used, problem_bytes, layouts = stored(database, batch)
                assert problem_bytes == size, (count, problem_bytes, size)
                grown[count] = used - used_before - layouts
            # The brief once, and per layout a job row and its events (under 2 KB each):
            # 200 briefs would be 36 MB.
            assert grown[200] < size + 200 * 2048, (grown, size)
            assert grown[200] < 10 * size, (grown, size)
            # Every layout still has its own problem: its seed, derived from the brief.
            lines = client.get(f"/v1/batches/{batch}/results",
                               params={"layouts": "false", "limit": 500}).text.splitlines()
            assert len(lines) == 200
    finally:
        s.stop()


def test_a_batch_s_layouts_derive_their_problems_from_the_one_brief(tmp_path: Path) -> None:
    store = JobStore(f"sqlite:///{tmp_path / 'jobs.db'}")
    brief = json.dumps(TINY)
    _, made = store.create_batch(owner="o", name="b", seed=40, vary_program=False,
                                 brief=brief, count=30, time_limit=2.0, time_ceiling=600,
                                 job_time_limit=6.0)
    with store.engine.begin() as conn:
        held = conn.execute(select(jobs.c.problem).where(
            jobs.c.batch_id == made[0].batch_id)).scalars().all()
    assert held == [None] * 30  # no job holds a copy of the brief
    for index in (0, 17, 29):
        job = store.get(made[index].id, owner="o")
        assert job is not None
        problem = Problem.model_validate_json(job.problem)
        assert problem.options.seed == 40 + index and problem.options.diverse
        assert [room.id for room in problem.rooms] == [room["id"] for room in TINY["rooms"]]
        assert (job.problem, job.time_limit) == layout_problem(brief, 40 + index, 2.0,
                                                               False, 600)
    # Deleting the batch's last job deletes the batch, its brief with it.
    for job in made:
        store.delete(job.id)
    assert store.get_batch(made[0].batch_id or "") is None


def test_a_claimed_layout_s_row_says_its_own_time_limit(tmp_path: Path) -> None:
    """With vary_program each layout's programme, and so its default limit, is its own:
    a layout's row holds the first layout's limit until it is claimed, then its own."""
    store = JobStore(f"sqlite:///{tmp_path / 'jobs.db'}")
    brief = (Path(__file__).resolve().parents[2] / "examples/flat-7-template.json").read_text()
    _, made = store.create_batch(owner="o", name="b", seed=0, vary_program=True, brief=brief,
                                 count=2, time_limit=None, time_ceiling=600,
                                 job_time_limit=layout_problem(brief, 0, None, True, 600)[1])
    own = [layout_problem(brief, k, None, True, 600)[1] for k in range(2)]
    assert own[0] != own[1]  # seed 1 draws six rooms, seed 0 seven
    while (job := store.claim_next()) is not None:
        assert job.time_limit == own[[m.id for m in made].index(job.id)]
    listed = {job.id: job.time_limit for job in store.list(owner="o", status=None, limit=10,
                                                           after=None)}
    assert [listed[job.id] for job in made] == own
