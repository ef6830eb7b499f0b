"""The workers' container health check (service/jobs/broker/health.py) against the
machine's Redis: the keys live workers renew, in a namespace of this test's own."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import uuid
from collections.abc import Iterator

import pytest
import redis

from floorplan.service.jobs.broker import health
from floorplan.service.jobs.broker.config import Keys
from floorplan.service.settings import Settings
from tests.servers import REDIS_URL


@pytest.fixture
def namespace() -> Iterator[str]:
    name = f"health-{uuid.uuid4().hex[:12]}"
    yield name
    client = redis.Redis.from_url(REDIS_URL)
    for key in client.scan_iter(f"{name}:*"):
        client.delete(key)
    client.close()


def test_its_defaults_are_the_settings_defaults() -> None:
    fields = Settings.model_fields
    assert fields["redis_url"].default == health.DEFAULT_REDIS_URL
    assert fields["namespace"].default == health.DEFAULT_NAMESPACE


def test_a_worker_of_this_host_is_alive_while_its_key_lasts(namespace: str) -> None:
    keys = Keys(namespace)
    host = socket.gethostname()
    client = redis.Redis.from_url(REDIS_URL)
    # Among other keys, as in a busy deployment: the scan goes on past pages without it.
    client.mset({f"{namespace}:job:{i}": "x" for i in range(2000)})
    assert not health.worker_alive(REDIS_URL, namespace)
    client.set(f"{keys.workers}{host}:4242", "1", ex=60)
    assert health.worker_alive(REDIS_URL, namespace)
    assert not health.worker_alive(REDIS_URL, namespace, subdomains=True)
    assert not health.worker_alive(REDIS_URL, namespace, host="another-host")
    client.set(f"{keys.subdomain_workers}{host}:4243", "2", ex=60)
    assert health.worker_alive(REDIS_URL, namespace, subdomains=True)
    client.close()


def test_a_redis_it_cannot_ask_means_not_alive(namespace: str) -> None:
    client = redis.Redis.from_url(REDIS_URL)
    client.set(f"{Keys(namespace).workers}{socket.gethostname()}:1", "1", ex=60)
    client.close()
    closed = f"redis://127.0.0.1:{_free_port()}/0"
    assert not health.worker_alive(closed, namespace)
    # The machine's Redis has no password: AUTH is an error reply, not a crash.
    with_password = REDIS_URL.replace("redis://", "redis://:secret@", 1)
    assert not health.worker_alive(with_password, namespace)
    assert health.worker_alive(REDIS_URL, namespace)


@pytest.mark.parametrize("argv", [["--subdomains"], []])
def test_run_as_a_module_it_exits_0_only_for_a_live_worker(namespace: str,
                                                           argv: list[str]) -> None:
    keys = Keys(namespace)
    prefix = keys.subdomain_workers if argv else keys.workers
    env = {**os.environ, "FLOORPLAN_REDIS_URL": REDIS_URL, "FLOORPLAN_NAMESPACE": namespace}
    check = [sys.executable, "-m", "floorplan.service.jobs.broker.health", *argv]
    assert subprocess.run(check, env=env).returncode == 1
    client = redis.Redis.from_url(REDIS_URL)
    client.set(f"{prefix}{socket.gethostname()}:7", "1", ex=60)
    client.close()
    assert subprocess.run(check, env=env).returncode == 0
    assert subprocess.run([*check, "--bogus"], env=env).returncode == 2


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
