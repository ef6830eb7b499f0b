"""Jobs are claimed fairly across keys (embedded mode): one key's batch cannot hold the
only solve slot while another key's single job waits behind all of it. Against a real
server process on loopback with one solve at a time; the order of the jobs' starts is
what is checked, not their times."""

from __future__ import annotations

import json
import time
from datetime import datetime
from pathlib import Path

import httpx2 as httpx
import pytest

from tests.servers import Server
from tests.service.test_service import SMALL

#: Each layout of the batch runs its whole limit (no first good layout ends it early
#: enough to matter): long enough that the batch is still queued when beta posts.
BUSY = {**SMALL, "options": {"time_limit": 3}}
BATCH = 8
WAIT = 300


def bearer(key: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"}


def started(client: httpx.Client, job_id: str, key: str) -> datetime:
    deadline = time.monotonic() + WAIT
    while True:
        job = client.get(f"/v1/layouts/{job_id}", headers=bearer(key)).json()
        if job.get("started_at"):
            return datetime.fromisoformat(job["started_at"])
        assert time.monotonic() < deadline, job
        time.sleep(0.2)


@pytest.mark.slow
def test_another_key_s_single_job_runs_next_not_after_the_batch(tmp_path: Path) -> None:
    """The review: another key's 1-s job waited 72 s behind a batch of 8 (first come,
    first served). Now it is the next job claimed once a slot frees."""
    server = Server(tmp_path, FLOORPLAN_API_KEYS="alpha,beta", WORKERS="1",
                    FLOORPLAN_SUBDOMAIN_PROCESSES="1").start()
    try:
        with httpx.Client(base_url=server.url, timeout=60) as client:
            made = client.post("/v1/batches", json={"problem": BUSY, "count": BATCH,
                                                    "time_limit": 3}, headers=bearer("alpha"))
            assert made.status_code == 202, made.text
            batch = made.json()["id"]
            single = client.post("/v1/layouts", json=SMALL, headers=bearer("beta"))
            assert single.status_code == 202, single.text
            beta_start = started(client, single.json()["id"], "beta")
            # The batch's layouts by index, with their start when they have one.
            deadline = time.monotonic() + WAIT
            while client.get(f"/v1/batches/{batch}", headers=bearer("alpha")).json()[
                    "status"] not in ("succeeded", "failed", "canceled"):
                assert time.monotonic() < deadline
                time.sleep(0.5)
            lines = client.get(f"/v1/batches/{batch}/results", params={"layouts": "false"},
                               headers=bearer("alpha")).text.splitlines()
            alpha_starts = sorted(started(client, json.loads(line)["job_id"], "alpha")
                                  for line in lines)
            assert len(alpha_starts) == BATCH
            # At most the batch's jobs already running when beta posted (one slot: one,
            # two when a slot freed between the two posts) started before beta's.
            before = sum(s < beta_start for s in alpha_starts)
            assert before <= 2, (before, beta_start, alpha_starts)
    finally:
        server.stop()
