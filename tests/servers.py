"""Real service processes for tests: `floorplan serve` alone (the embedded mode), or
an API node with Celery workers (the distributed mode)."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
import uuid
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest


class Server:
    """A `floorplan serve` process on a free loopback port, in its own session so that
    it and its solve processes can be killed together."""

    def __init__(self, data_dir: Path, **env: str) -> None:
        self.data_dir = data_dir
        self.env = env
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.process: subprocess.Popen[bytes] | None = None

    def start(self) -> Server:
        return self.start_logging(None)

    def start_logging(self, log: Any) -> Server:
        """Start with its stdout and stderr into `log` (an open file; None: inherited)."""
        env = {**os.environ, **self.env}
        self.process = subprocess.Popen(
            [sys.executable, "-m", "floorplan.service", "serve", "--port", str(self.port),
             "--data-dir", str(self.data_dir), "--workers", self.env.get("WORKERS", "2"),
             "--log-level", "warning"],
            env=env, start_new_session=True, stdout=log, stderr=log,
        )
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            try:
                if httpx.get(f"{self.url}/readyz", timeout=1).status_code == 200:
                    return self
            except httpx.TransportError:
                pass
            if self.process.poll() is not None:
                raise RuntimeError(f"the server exited with {self.process.returncode}")
            time.sleep(0.1)
        raise RuntimeError("the server did not become ready")

    def solver_parents(self) -> list[int]:
        """The processes whose children are solves: the server itself."""
        assert self.process is not None
        return [self.process.pid]

    def kill(self) -> None:
        """SIGKILL to the whole session: a crash, nothing gets to clean up."""
        assert self.process is not None
        os.killpg(self.process.pid, signal.SIGKILL)
        self.process.wait()

    def stop(self) -> None:
        assert self.process is not None
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()


def key_headers(env: dict[str, str]) -> dict[str, str]:
    """The first of FLOORPLAN_API_KEYS as a bearer token (no header without keys): what
    /readyz wants before it shows its figures."""
    keys = [k.strip() for k in env.get("FLOORPLAN_API_KEYS", "").split(",") if k.strip()]
    return {"Authorization": f"Bearer {keys[0]}"} if keys else {}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# The distributed mode: an API node and Celery workers as real processes, against the
# machine's PostgreSQL and Redis. Every cluster has its own PostgreSQL schema in the
# test database and its own Redis namespace, so tests never touch real data nor each
# other, and a cluster started again on the same data_dir finds its jobs again.

#: The machine's services (override to point the tests elsewhere).
POSTGRES_URL = os.environ.get("FLOORPLAN_TEST_POSTGRES", "postgresql://root@127.0.0.1:5432")
REDIS_URL = os.environ.get("FLOORPLAN_TEST_REDIS", "redis://127.0.0.1:6379/0")
TEST_DATABASE = "floorplan_test"
#: Short leases and reconciler passes, so that lost workers are noticed within seconds.
DISTRIBUTED_ENV = {"FLOORPLAN_BACKEND": "celery", "FLOORPLAN_LEASE_SECONDS": "4",
                   "FLOORPLAN_RECONCILE_SECONDS": "1"}
#: What this test session created, removed at its end (tests/conftest.py).
created_schemas: set[str] = set()
created_namespaces: set[str] = set()


def ensure_test_database() -> None:
    """Create the test database when it is missing (tests never use another)."""
    import psycopg

    with psycopg.connect(f"{POSTGRES_URL}/postgres", autocommit=True) as conn:
        found = conn.execute("SELECT 1 FROM pg_database WHERE datname = %s",
                             (TEST_DATABASE,)).fetchone()
        if found is None:  # another session may make it meanwhile
            with contextlib.suppress(psycopg.errors.DuplicateDatabase):
                conn.execute(f'CREATE DATABASE "{TEST_DATABASE}"')


def schema_url(schema: str) -> str:
    """The SQLAlchemy URL of `schema` in the test database, made if missing."""
    import psycopg

    ensure_test_database()
    with psycopg.connect(f"{POSTGRES_URL}/{TEST_DATABASE}", autocommit=True) as conn:
        conn.execute(f'CREATE SCHEMA IF NOT EXISTS "{schema}"')
    created_schemas.add(schema)
    base = POSTGRES_URL.replace("postgresql://", "postgresql+psycopg://", 1)
    return f"{base}/{TEST_DATABASE}?options=-csearch_path%3D{schema}"


def drop_schemas(schemas: set[str]) -> None:
    import psycopg

    with psycopg.connect(f"{POSTGRES_URL}/{TEST_DATABASE}", autocommit=True) as conn:
        for schema in schemas:
            conn.execute(f'DROP SCHEMA IF EXISTS "{schema}" CASCADE')


def forget_namespaces(redis_url: str, namespaces: set[str]) -> None:
    import redis

    client = redis.Redis.from_url(redis_url, socket_connect_timeout=2)
    try:
        for namespace in namespaces:
            keys = list(client.scan_iter(f"{namespace}:*", count=1000))
            if keys:
                client.delete(*keys)
    except redis.RedisError:
        pass  # a Redis restarted by a test keeps nothing anyway
    finally:
        client.close()


class Cluster:
    """The distributed topology from plain processes: one `floorplan serve` API node
    with FLOORPLAN_BACKEND=celery and `workers` `floorplan worker` processes, each in
    its own session. Same interface as Server; WORKERS is the solves per worker."""

    def __init__(self, data_dir: Path, workers: int = 1, redis_url: str = REDIS_URL,
                 **env: str) -> None:
        self.data_dir = data_dir
        data_dir.mkdir(parents=True, exist_ok=True)
        name_file = data_dir / "cluster-name"
        if not name_file.exists():
            name_file.write_text(f"fptest_{uuid.uuid4().hex[:12]}")
        self.name = name_file.read_text()
        created_namespaces.add(self.name)
        self.redis_url = redis_url
        self.env = {**DISTRIBUTED_ENV, "FLOORPLAN_DATABASE_URL": schema_url(self.name),
                    "FLOORPLAN_REDIS_URL": redis_url, "FLOORPLAN_NAMESPACE": self.name,
                    "FLOORPLAN_WORKERS": env.get("WORKERS", "2"), **env}
        self.api = Server(data_dir, **self.env)
        self.url = self.api.url
        self.worker_count = workers
        self.workers: list[subprocess.Popen[bytes]] = []
        self._logs: list[Any] = []

    @property
    def process(self) -> subprocess.Popen[bytes] | None:
        return self.api.process

    def start(self) -> Cluster:
        for k in range(self.worker_count):
            self.add_worker(f"w{k}")
        self.api.start()
        self.wait_for_workers(self.worker_count)
        return self

    def add_worker(self, name: str, *options: str,
                   log_level: str = "info") -> subprocess.Popen[bytes]:
        log = (self.data_dir / f"{name}.log").open("ab")
        self._logs.append(log)
        worker = subprocess.Popen(
            [sys.executable, "-m", "floorplan.service", "worker",
             "--hostname", f"{name}@{self.name}", "--log-level", log_level, *options],
            env={**os.environ, **self.env}, start_new_session=True, stdout=log, stderr=log,
        )
        self.workers.append(worker)
        return worker

    def add_subdomain_worker(self, name: str = "sub",
                             timeout: float = 60) -> subprocess.Popen[bytes]:
        """A `floorplan worker --subdomains` process (logging at info), once its liveness
        key is in Redis: it takes sub-domain tasks from then on."""
        import redis

        from floorplan.service.jobs.broker.config import Keys

        worker = self.add_worker(name, "--subdomains", log_level="info")
        client = redis.Redis.from_url(self.redis_url)
        try:
            deadline = time.monotonic() + timeout
            while not list(client.scan_iter(f"{Keys(self.name).subdomain_workers}*")):
                assert time.monotonic() < deadline, "the sub-domain worker did not start"
                time.sleep(0.2)
        finally:
            client.close()
        return worker

    def wait_for_workers(self, count: int, timeout: float = 60) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                ready = httpx.get(f"{self.url}/readyz", timeout=2,
                                  headers=key_headers(self.env)).json()
                if ready.get("workers", 0) >= count:
                    return
            except (httpx.TransportError, ValueError):
                pass
            time.sleep(0.2)
        raise RuntimeError(f"{count} workers did not become ready")

    def solver_parents(self) -> list[int]:
        """The processes whose children are solves: the workers."""
        return [w.pid for w in self.workers if w.poll() is None]

    def kill(self) -> None:
        """SIGKILL to every process of the cluster: a crash of every machine."""
        for worker in self.workers:
            _kill_session(worker)
        self.api.kill()
        self._close_logs()

    def stop(self) -> None:
        """SIGTERM to the workers (they hand their jobs back) and to the API."""
        for worker in self.workers:
            if worker.poll() is None:
                worker.send_signal(signal.SIGTERM)
        for worker in self.workers:
            try:
                worker.wait(timeout=30)
            except subprocess.TimeoutExpired:
                _kill_session(worker)
        self.api.stop()
        self._close_logs()

    def _close_logs(self) -> None:
        for log in self._logs:
            log.close()
        self._logs.clear()


def _kill_session(process: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()


#: The service's modes, as a fixture's params: a cluster of Celery workers is slow to start
#: and to stop, so its tests are left out by `pytest -m "not slow"`.
BACKENDS = ["embedded", pytest.param("celery", marks=pytest.mark.slow)]
#: The service in either mode.
AnyServer = Server | Cluster


def service(backend: str, data_dir: Path, **env: str) -> Server | Cluster:
    """The service in either mode, not yet started."""
    if backend == "celery":
        return Cluster(data_dir, **env)
    return Server(data_dir, **env)
