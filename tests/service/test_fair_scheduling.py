"""Jobs are claimed fairly across keys, in both modes (embedded on SQLite; an API node
with a Celery worker on PostgreSQL and Redis): one key's batch cannot hold the only
solve slot while another key's single job waits behind all of it. Against real server
processes on loopback with one solve at a time; the order of the jobs' starts is what
is checked, not their times."""

from __future__ import annotations

import time
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path

import httpx2 as httpx
import pytest

from tests.servers import BACKENDS, AnyServer, service
from tests.service.test_service import SMALL

#: Each layout of the batch runs its whole limit (no first good layout ends it early
#: enough to matter): long enough that the batch is still queued when beta posts.
BUSY = {**SMALL, "options": {"time_limit": 3}}
BATCH = 8
WAIT = 300


def bearer(key: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"}


@pytest.fixture(params=BACKENDS)
def server(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[AnyServer]:
    # One solve at a time: one worker of one slot in the distributed mode.
    s = service(str(request.param), tmp_path, FLOORPLAN_API_KEYS="alpha,beta", WORKERS="1",
                FLOORPLAN_SUBDOMAIN_PROCESSES="1").start()
    yield s
    s.stop()


def started(client: httpx.Client, job_id: str, key: str) -> datetime:
    deadline = time.monotonic() + WAIT
    while True:
        job = client.get(f"/v1/layouts/{job_id}", headers=bearer(key)).json()
        if job.get("started_at"):
            return datetime.fromisoformat(job["started_at"])
        assert time.monotonic() < deadline, job
        time.sleep(0.2)


@pytest.mark.slow
def test_another_key_s_single_job_runs_next_not_after_the_batch(server: AnyServer) -> None:
    """The review: another key's 1-s job waited 72 s behind a batch of 8 (first come,
    first served). Now it is the next job claimed once a slot frees; in the distributed
    mode too, where the worker's next message named one of the batch's layouts."""
    with httpx.Client(base_url=server.url, timeout=60) as client:
        made = client.post("/v1/batches", json={"problem": BUSY, "count": BATCH,
                                                "time_limit": 3}, headers=bearer("alpha"))
        assert made.status_code == 202, made.text
        batch = made.json()["id"]
        single = client.post("/v1/layouts", json=SMALL, headers=bearer("beta"))
        assert single.status_code == 202, single.text
        beta_start = started(client, single.json()["id"], "beta")
        page = client.get("/v1/layouts", params={"limit": 50}, headers=bearer("alpha")).json()
        alpha = [job for job in page["data"] if job.get("started_at")]
        before = [job["id"] for job in alpha
                  if datetime.fromisoformat(job["started_at"]) < beta_start]
        # At most the batch's jobs already running when beta posted (one slot: one, two
        # when a slot freed between the two posts) started before beta's.
        assert len(before) <= 2, (before, beta_start, alpha)
        assert len(page["data"]) == BATCH  # the batch waits on: it was not run first
        client.post(f"/v1/batches/{batch}/cancel", headers=bearer("alpha"))
        deadline = time.monotonic() + WAIT
        while client.get(f"/v1/batches/{batch}", headers=bearer("alpha")).json()[
                "status"] in ("queued", "running"):
            assert time.monotonic() < deadline
            time.sleep(0.2)
