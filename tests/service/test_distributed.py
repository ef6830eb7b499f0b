"""The distributed mode's promises, against real Celery worker processes, the machine's
PostgreSQL and Redis: a worker killed mid-job, a cancel reaching the worker that holds
the job, a Redis restart, the store's claims and leases, and the schema migrations.
(The HTTP API itself runs against both backends in test_service.py.)"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest
import redis
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import Connection, text, update

from floorplan.models.jobs import JobStatus
from floorplan.service.records import Job
from floorplan.service.store import JobStore
from floorplan.service.tables import jobs, metadata
from tests.paths import ROOT
from tests.servers import Cluster, free_port, schema_url
from tests.service.test_service import LONG, SMALL, TERMINAL, solve_processes, submit, wait


def store_of(cluster: Cluster) -> JobStore:
    return JobStore(cluster.env["FLOORPLAN_DATABASE_URL"], migrate=False)


def holder_pid(store: JobStore, job_id: str) -> int:
    """The process id of the worker holding a job (`host:pid:claim`)."""
    job = store.get(job_id)
    assert job is not None and job.worker is not None
    return int(job.worker.rsplit(":", 2)[1])


def running(pid: int) -> bool:
    """Alive and not a zombie (an orphan's reaper may be slow to collect it)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False
    return state not in ("Z", "X")


def status_events(client: httpx.Client, job_id: str) -> list[dict[str, Any]]:
    import json

    with client.stream("GET", f"/v1/layouts/{job_id}/events") as stream:
        lines = list(stream.iter_lines())
    return [json.loads(lines[k + 1][6:]) for k, line in enumerate(lines[:-1])
            if line == "event: status"]



def wait_for_incumbent(client: httpx.Client, job_id: str, timeout: float = 30) -> None:
    """Until the running job has a best-so-far layout to return."""
    deadline = time.monotonic() + timeout
    while client.get(f"/v1/layouts/{job_id}/result").status_code != 200:
        assert time.monotonic() < deadline, f"no incumbent in {timeout:.0f} s"
        time.sleep(0.2)

@pytest.mark.slow
def test_a_worker_killed_mid_job_runs_it_again_on_another_worker(tmp_path: Path) -> None:
    cluster = Cluster(tmp_path, workers=2, WORKERS="1").start()
    store = store_of(cluster)
    try:
        with httpx.Client(base_url=cluster.url, timeout=30) as client:
            job = submit(client, {**LONG, "options": {"time_limit": 4}})
            wait(client, job["id"], until={"running"})
            first = holder_pid(store, job["id"])
            solves = solve_processes(first)
            assert solves, "the job's solve runs in a child of its worker"
            # Only the worker process dies (SIGKILL): no hand-back, no ack.
            next(w for w in cluster.workers if w.pid == first).kill()

            # Its solve processes notice and stop: no orphan keeps solving.
            deadline = time.monotonic() + 60
            while any(running(pid) for pid in solves):
                assert time.monotonic() < deadline, "the dead worker's solves go on"
                time.sleep(0.2)

            done = wait(client, job["id"], timeout=60)
            assert done["status"] == "succeeded" and done["attempts"] == 2
            assert holder_pid(store, job["id"]) != first
            statuses = status_events(client, job["id"])
            assert [s["status"] for s in statuses] == ["running", "queued", "running",
                                                       "succeeded"]
            assert "stopped answering" in statuses[1]["detail"]
            result = client.get(f"/v1/layouts/{job['id']}/result").json()
            assert result["report"]["valid"]
    finally:
        cluster.stop()


@pytest.mark.slow
def test_a_cancel_reaches_the_worker_holding_the_job_and_keeps_its_incumbent(
    tmp_path: Path,
) -> None:
    # A long lease: the worker reads the cancel flag only every 5 s there, so a
    # prompt stop comes through Redis pub/sub.
    cluster = Cluster(tmp_path, workers=2, WORKERS="1", FLOORPLAN_LEASE_SECONDS="60").start()
    store = store_of(cluster)
    try:
        with httpx.Client(base_url=cluster.url, timeout=30) as client:
            job = submit(client, LONG)
            wait_for_incumbent(client, job["id"])
            worker = holder_pid(store, job["id"])
            assert worker in [w.pid for w in cluster.workers]
            # Heard on the channel the workers listen on, as they hear it.
            with redis.Redis.from_url(cluster.redis_url).pubsub() as heard:
                heard.subscribe(f"{cluster.env['FLOORPLAN_NAMESPACE']}:cancel")
                subscribed = heard.get_message(timeout=30)
                assert subscribed is not None and subscribed["type"] == "subscribe"
                assert client.post(f"/v1/layouts/{job['id']}/cancel").status_code == 200
                message = heard.get_message(timeout=60)
            assert message is not None and message["data"] == job["id"].encode()
            done = wait(client, job["id"], timeout=60)
            assert done["status"] == "canceled" and done["termination"] == "interrupted"
            result = client.get(f"/v1/layouts/{job['id']}/result").json()
            assert result["report"]["valid"] and len(result["rooms"]) == 12
            # The worker carries on with the next job.
            assert wait(client, submit(client, SMALL)["id"])["status"] == "succeeded"
        # The container health check of a worker (the light module compose runs, and the
        # command's option): one of this host is alive.
        env = {**os.environ, **cluster.env}
        for health in ([sys.executable, "-m", "floorplan.service.jobs.broker.health"],
                       [sys.executable, "-m", "floorplan.service", "worker", "--health"]):
            assert subprocess.run(health, env=env).returncode == 0
            elsewhere = {**env, "FLOORPLAN_NAMESPACE": "none"}
            assert subprocess.run(health, env=elsewhere).returncode == 1
    finally:
        cluster.stop()


@pytest.mark.slow
def test_a_cancel_whose_message_is_lost_still_reaches_the_worker(tmp_path: Path) -> None:
    # The flag in PostgreSQL alone, as when the pub/sub message is lost: the worker reads
    # it when it renews its lease (every second with the tests' 4 s lease).
    cluster = Cluster(tmp_path, workers=1, WORKERS="1").start()
    store = store_of(cluster)
    try:
        with httpx.Client(base_url=cluster.url, timeout=30) as client:
            job = submit(client, LONG)
            wait_for_incumbent(client, job["id"])
            store.request_cancel(job["id"])  # no message on Redis
            done = wait(client, job["id"], timeout=60)
            assert done["status"] == "canceled" and done["termination"] == "interrupted"
            assert client.get(f"/v1/layouts/{job['id']}/result").json()["report"]["valid"]
    finally:
        cluster.stop()


class RedisServer:
    """A redis-server of this test's own on a free loopback port, with the machine's
    options (nothing kept on disk), so that stopping it disturbs nobody else."""

    def __init__(self, directory: Path) -> None:
        self.port = free_port()
        self.url = f"redis://127.0.0.1:{self.port}/0"
        self.directory = directory
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        self.process = subprocess.Popen(
            ["redis-server", "--port", str(self.port), "--bind", "127.0.0.1", "--save", "",
             "--appendonly", "no", "--dir", str(self.directory),
             "--logfile", str(self.directory / "redis.log")],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        client = redis.Redis(port=self.port, socket_connect_timeout=1)
        deadline = time.monotonic() + 60
        while True:
            try:
                if client.ping():
                    break
            except redis.ConnectionError:
                assert time.monotonic() < deadline, "redis-server did not start"
                time.sleep(0.05)
        client.close()

    def stop(self) -> None:
        """Shut down without saving: whatever it held is gone, as after a crash."""
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait()


@contextmanager
def own_redis(directory: Path) -> Iterator[RedisServer]:
    server = RedisServer(directory)
    server.start()
    try:
        yield server
    finally:
        server.stop()


@pytest.mark.slow
def test_a_redis_restart_loses_no_accepted_job(tmp_path: Path) -> None:
    with own_redis(tmp_path) as broker:
        cluster = Cluster(tmp_path / "cluster", workers=1, WORKERS="1",
                          redis_url=broker.url).start()
        try:
            with httpx.Client(base_url=cluster.url, timeout=30) as client:
                busy = submit(client, {**LONG, "options": {"time_limit": 6}})
                wait(client, busy["id"], until={"running"})
                waiting = [submit(client, {**SMALL, "name": f"waiting-{k}"})["id"]
                           for k in range(2)]  # in the broker's queue, behind `busy`

                broker.stop()  # the queue and the unacknowledged task are gone
                during = submit(client, {**SMALL, "name": "while-redis-is-down"})["id"]
                ready = client.get("/readyz")
                assert ready.status_code == 200 and ready.json()["broker"] == "down"
                broker.start()

                for job_id in [busy["id"], *waiting, during]:
                    done = wait(client, job_id, timeout=90)
                    assert done["status"] == "succeeded", done
                # The worker went on solving through the restart.
                assert client.get(f"/v1/layouts/{busy['id']}").json()["attempts"] == 1
        finally:
            cluster.stop()


@pytest.mark.slow
def test_sub_domains_go_as_celery_tasks_to_a_sub_domain_worker(tmp_path: Path) -> None:
    from tests.solver.pipeline.test_parallel import TWO_WINGS

    cluster = Cluster(tmp_path, workers=1, WORKERS="1", FLOORPLAN_SUBDOMAINS="celery").start()
    try:
        cluster.add_subdomain_worker()
        with httpx.Client(base_url=cluster.url, timeout=30) as client:
            job = submit(client, TWO_WINGS)
            done = wait(client, job["id"])
            assert done["status"] == "succeeded", done
            result = client.get(f"/v1/layouts/{job['id']}/result").json()
            assert result["report"]["valid"] and len(result["rooms"]) == 4
        log = (tmp_path / "sub.log").read_text()
        solved = re.findall(r"Task floorplan\.subdomain\[[^]]+\] succeeded", log)
        assert len(solved) >= 2, log[-2000:]  # both wings of at least one level
    finally:
        cluster.stop()


# The store under several workers, on PostgreSQL.


@pytest.fixture
def pg_store() -> JobStore:
    return JobStore(schema_url(f"fptest_{uuid.uuid4().hex[:12]}"))


def test_a_job_is_claimed_once_and_a_stale_worker_can_no_longer_write(
    pg_store: JobStore,
) -> None:
    job, _ = pg_store.create(problem="{}", time_limit=1)
    assert pg_store.claim(job.id, "a:1:x") is not None
    assert pg_store.claim(job.id, "b:2:y") is None  # a duplicate delivery does nothing
    assert pg_store.heartbeat(job.id, "a:1:x") is False
    # Worker a stops answering; the reconciler gives the job to b.
    assert pg_store.requeue_stale(lease_seconds=-1, retry_limit=2) == [job.id]
    assert pg_store.claim(job.id, "b:2:y") is not None
    assert pg_store.heartbeat(job.id, "a:1:x") is None  # a learns it lost the job
    assert not pg_store.finish(job.id, JobStatus.SUCCEEDED, result="{}", worker="a:1:x")
    assert pg_store.finish(job.id, JobStatus.SUCCEEDED, result="{}", worker="b:2:y")
    final = pg_store.get(job.id)
    assert final is not None and final.status is JobStatus.SUCCEEDED and final.attempts == 2


def test_workers_claim_fairly_across_keys_whichever_job_the_message_names(
    pg_store: JobStore,
) -> None:
    batch = [pg_store.create(problem="{}", time_limit=1, owner="alpha")[0] for _ in range(4)]
    single, _ = pg_store.create(problem="{}", time_limit=1, owner="beta")
    first = pg_store.claim_fair(batch[0].id, "w:1:a")
    assert first is not None and first.owner in ("alpha", "beta")
    # Every message after it names one of alpha's layouts; the key with nothing running
    # is served next, then the other, alpha's jobs oldest first.
    claimed = [first] + [pg_store.claim_fair(job.id, f"w:{k}:b") for k, job in
                         enumerate(batch[1:], start=2)]
    owners = [job.owner for job in claimed if job is not None]
    assert sorted(owners[:2]) == ["alpha", "beta"], owners
    assert [job.id for job in claimed if job is not None and job.owner == "alpha"] == [
        job.id for job in batch[:3]]
    # Five claims for five jobs: the message left over finds the last one, none after.
    last = pg_store.claim_fair(single.id, "w:9:c")
    assert last is not None and last.id == batch[3].id
    assert pg_store.claim_fair(single.id, "w:9:d") is None


def test_concurrent_fair_claims_take_each_job_once(pg_store: JobStore) -> None:
    made = [pg_store.create(problem="{}", time_limit=1, owner=f"k{n % 3}")[0]
            for n in range(12)]
    barrier = threading.Barrier(12)
    taken: list[str | None] = [None] * 12

    def claim(k: int) -> None:
        barrier.wait()
        job = pg_store.claim_fair(made[k].id, f"w:{k}:x")
        taken[k] = job.id if job is not None else None

    threads = [threading.Thread(target=claim, args=(k,)) for k in range(12)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    # Twelve messages, twelve jobs: each job claimed by exactly one of them.
    assert sorted(t for t in taken if t is not None) == sorted(job.id for job in made)


def test_a_message_claims_its_job_while_another_writer_holds_the_row(
    pg_store: JobStore,
) -> None:
    # The API marks a job dispatched just after sending its message; a worker quick
    # enough read the row as locked, skipped it, found nothing queued and dropped the
    # message, and the job stayed queued for good (seen on CI: "still queued after 60 s").
    job, _ = pg_store.create(problem="{}", time_limit=1)
    claimed: list[Job | None] = []
    with pg_store.engine.connect() as writer:
        writer.execute(update(jobs).where(jobs.c.id == job.id).values(dispatched_at=time.time()))
        claimer = threading.Thread(target=lambda: claimed.append(
            pg_store.claim_fair(job.id, "w:1:x")))
        claimer.start()
        deadline = time.monotonic() + 60
        while claimer.is_alive() and not lock_waits(writer):
            assert time.monotonic() < deadline, "the claim neither ended nor waited"
            time.sleep(0.05)
        writer.commit()  # the writer lets go; the waiting claim goes on
    claimer.join(timeout=60)
    assert claimed and claimed[0] is not None and claimed[0].id == job.id


def lock_waits(conn: Connection) -> int:
    """Sessions of this database waiting on a lock (a row lock held by `conn`). The
    activity view is a snapshot kept for the transaction: cleared to read it again."""
    conn.execute(text("SELECT pg_stat_clear_snapshot()"))
    return int(conn.execute(text(
        "SELECT count(*) FROM pg_stat_activity WHERE datname = current_database() "
        "AND wait_event_type = 'Lock'")).scalar_one())


def test_lost_jobs_fail_after_the_retry_limit_and_canceled_ones_end_canceled(
    pg_store: JobStore,
) -> None:
    tried, _ = pg_store.create(problem="{}", time_limit=1)
    for k in range(3):
        assert pg_store.claim(tried.id, f"w:{k}:x") is not None
        pg_store.requeue_stale(lease_seconds=-1, retry_limit=2)
    final = pg_store.get(tried.id)
    assert final is not None and final.status is JobStatus.FAILED
    assert final.error is not None and final.error["code"] == "retries_exhausted"

    canceled, _ = pg_store.create(problem="{}", time_limit=1)
    pg_store.claim(canceled.id, "w:9:x")
    pg_store.request_cancel(canceled.id)
    assert pg_store.requeue_stale(lease_seconds=-1, retry_limit=2) == []
    ended = pg_store.get(canceled.id)
    assert ended is not None and ended.status is JobStatus.CANCELED


def test_a_job_left_running_by_an_embedded_runner_is_requeued(pg_store: JobStore) -> None:
    job, _ = pg_store.create(problem="{}", time_limit=1)
    claimed = pg_store.claim_next()  # the embedded runner's claim: no lease
    assert claimed is not None and claimed.heartbeat_at is None
    assert pg_store.requeue_stale(lease_seconds=30, retry_limit=2) == [job.id]


def test_an_undispatched_job_is_taken_by_one_reconciler_only(pg_store: JobStore) -> None:
    job, _ = pg_store.create(problem="{}", time_limit=1)
    later = time.time() + 1
    assert pg_store.take_undispatched(later) == [job.id]
    assert pg_store.take_undispatched(later) == []
    pg_store.mark_dispatched(job.id, False)  # the send failed: up for grabs again
    assert pg_store.take_undispatched(later) == [job.id]


# One schema for both stores, kept by Alembic.


def test_migrations_build_the_same_schema_on_sqlite_and_postgresql(tmp_path: Path) -> None:
    for store in (JobStore.sqlite(tmp_path / "jobs.sqlite3"),
                  JobStore(schema_url(f"fptest_{uuid.uuid4().hex[:12]}"))):
        with store.engine.connect() as conn:
            assert compare_metadata(MigrationContext.configure(conn), metadata) == []


@pytest.mark.slow
def test_an_embedded_store_from_before_migrations_is_upgraded_in_place(tmp_path: Path) -> None:
    # The first revision's tables, as `create_all` made them, with a job in them.
    path = tmp_path / "jobs.sqlite3"
    script = (
        "import sqlalchemy as sa, sys\n"
        "from alembic.migration import MigrationContext\n"
        "from alembic.operations import Operations\n"
        "import importlib.util\n"
        "spec = importlib.util.spec_from_file_location('m', sys.argv[2])\n"
        "m = importlib.util.module_from_spec(spec); spec.loader.exec_module(m)\n"
        "engine = sa.create_engine('sqlite:///' + sys.argv[1])\n"
        "with engine.begin() as conn:\n"
        "    ops = Operations(MigrationContext.configure(conn))\n"
        "    m.op = ops; m.upgrade()\n"
        "    conn.execute(sa.text(\"INSERT INTO jobs (id, owner, status, problem, time_limit,"
        " attempts, cancel_requested, created_at, updated_at) VALUES ('old', '', 'queued',"
        " '{}', 1, 0, 0, 1, 1)\"))\n"
    )
    first = ROOT / "service/migrations/versions"
    subprocess.run([sys.executable, "-c", script, str(path),
                    str(first / "0001_jobs_and_events.py")], check=True)
    store = JobStore.sqlite(path)
    old = store.get("old")
    assert old is not None and old.status is JobStatus.QUEUED and old.worker is None
    with store.engine.connect() as conn:
        assert compare_metadata(MigrationContext.configure(conn), metadata) == []


def test_terminal_statuses_are_the_ones_the_tests_wait_for() -> None:
    assert {s.value for s in JobStatus if s.terminal} == TERMINAL
