"""scripts/run-distributed.sh: the distributed topology from plain processes (the
machine's PostgreSQL and Redis, Celery workers, uvicorn) starts, solves, and stops
cleanly on SIGTERM."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import httpx2 as httpx
import pytest

from tests.paths import ROOT
from tests.servers import (
    DISTRIBUTED_ENV,
    REDIS_URL,
    created_namespaces,
    free_port,
    schema_url,
)
from tests.service.test_service import SMALL, submit, wait

#: End to end (the distributed topology from plain processes): left out by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow

SCRIPT = ROOT / "scripts" / "run-distributed.sh"


def test_the_start_script_runs_the_topology_and_stops_it(tmp_path: Path) -> None:
    name = f"fptest_{uuid.uuid4().hex[:12]}"
    created_namespaces.add(name)
    port = free_port()
    env = {**os.environ, **DISTRIBUTED_ENV, "PYTHON": sys.executable,
           "FLOORPLAN_DATABASE_URL": schema_url(name), "FLOORPLAN_REDIS_URL": REDIS_URL,
           "FLOORPLAN_NAMESPACE": name}
    script = subprocess.Popen(
        ["bash", str(SCRIPT), "--workers", "2", "--subdomain-workers", "1", "--port",
         str(port), "--logs", str(tmp_path / "logs")],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        start_new_session=True,
    )
    try:
        assert script.stdout is not None
        lines: list[str] = []
        deadline = time.monotonic() + 90
        while not any("ready at" in line for line in lines):
            line = script.stdout.readline()
            assert line, f"the script ended: {lines}"
            lines.append(line)
            assert time.monotonic() < deadline, lines
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30) as client:
            ready = client.get("/readyz").json()
            assert ready["backend"] == "celery" and ready["workers"] == 2
            assert wait(client, submit(client, SMALL)["id"])["status"] == "succeeded"
        children = subprocess.run(["ps", "-o", "pid=", "--ppid", str(script.pid)],
                                  capture_output=True, text=True).stdout.split()
        assert len(children) == 4  # two workers, a sub-domain worker and the API node

        script.send_signal(signal.SIGTERM)
        assert script.wait(timeout=60) == 0
        for pid in map(int, children):
            assert not Path(f"/proc/{pid}").exists() or \
                Path(f"/proc/{pid}/stat").read_text().split(")")[1].split()[0] == "Z"
    finally:
        if script.poll() is None:
            os.killpg(script.pid, signal.SIGKILL)
            script.wait()
