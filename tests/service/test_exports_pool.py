"""Exports are made in the API's own export processes, a bounded number at once: six
concurrent IFC exports of a solved layout hold up neither /healthz nor each other's
event loop. Against a real server process on loopback; the measure is a share of the
exports' own time, not seconds (both grow on a busy machine)."""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path

import httpx2 as httpx
import pytest

from tests.paths import ROOT
from tests.servers import Server
from tests.service.test_service import wait

OFFICES = json.loads((ROOT / "examples" / "office-regions.json").read_text())
WAIT = 300


def cpu_seconds(pid: int) -> float:
    """User and system CPU time of process `pid`'s own threads (not its children)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.slow
def test_concurrent_ifc_exports_hold_up_nothing(tmp_path: Path) -> None:
    server = Server(tmp_path, WORKERS="1", FLOORPLAN_SUBDOMAIN_PROCESSES="1",
                    FLOORPLAN_EXPORT_PROCESSES="2").start()
    try:
        with httpx.Client(base_url=server.url, timeout=WAIT) as client:
            brief = {**OFFICES, "options": {**OFFICES.get("options", {}), "time_limit": 30}}
            made = client.post("/v1/layouts", json=brief)
            assert made.status_code == 202, made.text
            job = wait(client, made.json()["id"], timeout=WAIT)
            assert job["status"] == "succeeded", job
            url = f"/v1/layouts/{job['id']}/result"
            answers: list[httpx.Response] = []

            def export() -> None:
                with httpx.Client(base_url=server.url, timeout=WAIT) as own:
                    answers.append(own.get(url, params={"format": "ifc"}))

            calls = [threading.Thread(target=export) for _ in range(6)]
            assert server.process is not None
            cpu_before = cpu_seconds(server.process.pid)
            for call in calls:
                call.start()
            slowest = 0.0
            rounds = 0
            while any(call.is_alive() for call in calls):
                started = time.monotonic()
                assert client.get("/healthz").status_code == 200
                slowest = max(slowest, time.monotonic() - started)
                rounds += 1
                time.sleep(0.05)
            for call in calls:
                call.join()
            api_cpu = cpu_seconds(server.process.pid) - cpu_before
            assert [a.status_code for a in answers] == [200] * 6
            assert all(a.content.startswith(b"ISO-10303-21;") for a in answers)
            quickest = min(a.elapsed.total_seconds() for a in answers)
            # The exports' work was done elsewhere: the API process itself spent less
            # CPU on all six than one export takes (in its threads it spent six
            # exports' worth, and /healthz waited 1.6 s for the GIL).
            assert api_cpu < quickest / 2, (api_cpu, quickest)
            assert slowest < quickest / 2, (slowest, quickest)
            assert rounds >= 3
            print(f"/healthz {slowest:.3f} s at most; exports {quickest:.2f} s at least; "
                  f"the API process's CPU {api_cpu:.2f} s")
    finally:
        server.stop()
