"""Broker messages are checked at the worker's door (the distributed mode, real Redis
and PostgreSQL, real worker processes): a solve task naming no job is acknowledged and
dropped once, never requeued, and holds up no real job; a sub-domain task whose budget
or deadline no solve of this service sends is refused before it runs, and one that
runs past the worker's hard time limit is killed, in a worker that really is a prefork
pool."""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import httpx2 as httpx
import pytest
import redis
from celery.exceptions import TimeLimitExceeded

from floorplan.service.jobs.broker.codec import decode_outcome, encode_task
from floorplan.service.jobs.broker.config import SUBDOMAIN_TASK, TASK_NAME, Keys, make_celery
from floorplan.service.settings import Settings
from floorplan.solver.geometry.boxes import Box
from floorplan.solver.miqp.spec import LevelSpec, RectSpec
from floorplan.solver.pipeline.subdomains import SubdomainTask
from tests.servers import Cluster
from tests.service.test_security_broker import full_task
from tests.service.test_service import SMALL, wait

#: Bounded waits, not speed claims.
WAIT = 120
#: What a writer to Redis put in the job queue: no job ids, the review's among them.
POISON: list[object] = ["abc\x00def"] * 21 + [42, ["x"], "0" * 36,
                                              "00000000-0000-0000-0000-00000000000z"]
DROPPED = "dropped a message that names no job"


def children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


@pytest.mark.slow
def test_poison_solve_messages_are_dropped_once_and_hold_up_no_job(tmp_path: Path) -> None:
    cluster = Cluster(tmp_path / "cluster", workers=1, WORKERS="1").start()
    celery = make_celery(Settings(redis_url=cluster.redis_url, namespace=cluster.name))
    try:
        for value in POISON:
            celery.send_task(TASK_NAME, args=[value], queue=cluster.name)
        with httpx.Client(base_url=cluster.url, timeout=30) as client:
            made = client.post("/v1/layouts", json=SMALL)
            assert made.status_code == 202, made.text
            done = wait(client, made.json()["id"], timeout=WAIT)
            assert done["status"] == "succeeded", done
        log = tmp_path / "cluster" / "w0.log"
        deadline = time.monotonic() + WAIT
        while log.read_text().count(DROPPED) < len(POISON):
            assert time.monotonic() < deadline, log.read_text()[-3000:]
            time.sleep(0.2)
        # Dropped, not handed back: a few seconds on, no message came round again
        # (before, each was requeued every 2 s forever).
        time.sleep(5)
        assert log.read_text().count(DROPPED) == len(POISON)
        assert "Traceback" not in log.read_text()
        queue = redis.Redis.from_url(cluster.redis_url)
        try:
            assert queue.llen(f"{cluster.name}:{Keys(cluster.name).queue}") == 0
        finally:
            queue.close()
    finally:
        celery.close()
        cluster.stop()


def heavy_task(rects: int = 1000) -> SubdomainTask:
    """A task within every limit whose model alone takes far longer than the worker's
    hard time limit (6 s) to build: what a sub-domain that overruns its budget looks
    like, since its budget is checked only before the model is built. The time grows
    with the square of the count: 400 rectangles took 5.3 s on an idle 2-core machine,
    short of the limit (the build ended and the task failed otherwise), so 1000, some
    30 s, whatever the machine; the pool process is killed at the limit all the same."""
    spec = LevelSpec(name="heavy", region=Box(0, 0, 100, 100), blocked=(), free_area=1e4,
                     rects=tuple(RectSpec(name=f"r{k}", room=f"room{k}", min_size=(1.0, 1.0),
                                          max_size=(10.0, 10.0), target=(3.0, 3.0))
                                 for k in range(rects)))
    return SubdomainTask(spec=spec, start={}, budget=1.0, deadline=time.time() + 5, seed=0)


@pytest.mark.slow
def test_a_sub_domain_task_beyond_the_time_limit_is_refused_or_killed_in_a_prefork_pool(
        tmp_path: Path) -> None:
    """Refused at the door when its budget or deadline is beyond FLOORPLAN_MAX_TIME_LIMIT;
    killed by the pool's hard time limit (FLOORPLAN_MAX_TIME_LIMIT + 5 s) when it runs
    past it all the same, failing that task only: the worker and its next task go on."""
    cluster = Cluster(tmp_path / "cluster", workers=1, WORKERS="1",
                      FLOORPLAN_SUBDOMAINS="celery", FLOORPLAN_MAX_TIME_LIMIT="1").start()
    celery = make_celery(Settings(redis_url=cluster.redis_url, namespace=cluster.name))
    try:
        sub = cluster.add_subdomain_worker(timeout=WAIT)
        keys = Keys(cluster.name)
        # Prefork: the worker's pool processes are its children (a thread pool has
        # none), where Celery's hard time limit applies.
        pool = children(sub.pid)
        assert pool, "no pool processes: the worker runs threads"
        now = time.time()
        for bad in (replace(full_task(), budget=1e6, deadline=now + 1e6),
                    replace(full_task(), budget=1.0, deadline=now + 1e6)):
            result = celery.send_task(SUBDOMAIN_TASK, args=[encode_task(bad)],
                                      queue=keys.subdomains)
            with pytest.raises(Exception, match=r"task\.(budget|deadline)"):
                result.get(timeout=WAIT)
        # Within the limits, but running past the hard limit: its pool process is
        # killed, and the task fails.
        heavy = celery.send_task(SUBDOMAIN_TASK, args=[encode_task(heavy_task())],
                                 queue=keys.subdomains)
        with pytest.raises(TimeLimitExceeded):
            heavy.get(timeout=WAIT)
        log = tmp_path / "cluster" / "sub.log"
        killed = [f"pid:{pid} exited with 'signal 9 (SIGKILL)'" for pid in pool]
        deadline = time.monotonic() + WAIT
        while not any(line in log.read_text() for line in killed):
            assert time.monotonic() < deadline, log.read_text()[-3000:]
            time.sleep(0.2)
        assert "Hard time limit (6.0s) exceeded" in log.read_text()
        # Only that task: the same worker, a new pool process, and the next task runs.
        assert sub.poll() is None
        deadline = time.monotonic() + WAIT
        while not (replaced := children(sub.pid)) or set(replaced) == set(pool):
            assert time.monotonic() < deadline, "the killed pool process was not replaced"
            time.sleep(0.2)
        fine = celery.send_task(SUBDOMAIN_TASK, args=[encode_task(
            replace(full_task(), budget=0.0, deadline=time.time() + 5))],
            queue=keys.subdomains)
        assert decode_outcome(fine.get(timeout=WAIT)).status.startswith("not started")
    finally:
        celery.close()
        cluster.stop()
