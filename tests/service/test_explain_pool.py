"""POST /v1/validate?explain=true when an explain process dies (killed, as the OOM killer
would): the call it held answers 503 and the pool is replaced, /readyz says so once,
and later explanations work. Against a real server process on loopback; the explain
process is found among the server's children and killed with SIGKILL."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import httpx2 as httpx
import pytest

from tests.servers import Server
from tests.service.test_security_requests import TIGHT
from tests.service.test_service import SMALL

QUIET = {"WORKERS": "1", "FLOORPLAN_SUBDOMAIN_PROCESSES": "1",
         "FLOORPLAN_EXPLAIN_PROCESSES": "1"}
#: A bounded wait, not a speed claim.
WAIT = 120


@pytest.fixture
def server(tmp_path: Path) -> Iterator[Server]:
    running = Server(tmp_path, **QUIET).start()
    yield running
    running.stop()


def explain_processes(server: Server) -> list[int]:
    """The server's children that run explanations: the spawned pool processes (not
    multiprocessing's resource tracker)."""
    assert server.process is not None
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ")
        except OSError:
            continue
        parent = int(stat.rsplit(")", 1)[1].split()[1])
        if (parent == server.process.pid and b"multiprocessing" in cmdline
                and b"resource_tracker" not in cmdline):
            found.append(int(entry.name))
    return found


def explain(client: httpx.Client, seconds: float = 2) -> httpx.Response:
    return client.post("/v1/validate", json=TIGHT,
                       params={"explain": "true", "time_limit": str(seconds)})


@pytest.mark.slow
def test_an_explanation_whose_process_is_killed_is_a_503_and_the_next_works(
        server: Server) -> None:
    with httpx.Client(base_url=server.url, timeout=WAIT) as client:
        assert explain(client).status_code == 200  # the pool's process is up
        answer: dict[str, httpx.Response] = {}
        call = threading.Thread(target=lambda: answer.setdefault("r", explain(client, 30)))
        call.start()
        deadline = time.monotonic() + WAIT
        while not (victims := explain_processes(server)):
            assert time.monotonic() < deadline
            time.sleep(0.1)
        time.sleep(1)  # the call is in the process by now (a 30-s explanation)
        for pid in victims:
            os.kill(pid, signal.SIGKILL)
        call.join(WAIT)
        lost = answer["r"]
        assert lost.status_code == 503, lost.text
        assert lost.headers["content-type"] == "application/problem+json"
        assert lost.json()["type"].endswith("/explain-unavailable")
        assert int(lost.headers["retry-after"]) > 0
        # Before, this and every later explanation was a 500 BrokenProcessPool.
        for _ in range(2):
            again = explain(client)
            assert again.status_code == 200, again.text
            assert again.json()["feasible"] is not True
        assert client.post("/v1/validate", json=SMALL).json()["valid"]
        assert client.get("/readyz").status_code == 200


@pytest.mark.slow
def test_readyz_reports_a_lost_explain_process_and_the_pool_comes_back(
        server: Server) -> None:
    with httpx.Client(base_url=server.url, timeout=WAIT) as client:
        assert explain(client).status_code == 200
        victims = explain_processes(server)
        assert victims
        for pid in victims:
            os.kill(pid, signal.SIGKILL)
        # The executor notices the death in its own thread: a bounded wait for it.
        deadline = time.monotonic() + WAIT
        while (ready := client.get("/readyz")).status_code == 200:
            assert time.monotonic() < deadline
            time.sleep(0.1)
        assert ready.status_code == 503
        assert ready.json()["explain"] == "replaced"
        assert client.get("/readyz").status_code == 200
        assert explain(client).status_code == 200


def in_session(sid: int) -> list[str]:
    """The processes of session `sid` still alive (zombies aside), as 'pid cmdline'."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":
            found.append(f"{entry.name} {cmdline[:120]}")
    return found


@pytest.mark.slow
@pytest.mark.parametrize("how", [signal.SIGTERM, signal.SIGKILL], ids=["stopped", "killed"])
def test_no_explain_process_outlives_the_server(tmp_path: Path, how: signal.Signals) -> None:
    """Stopped (SIGTERM) or killed (SIGKILL, as the OOM killer would) while one
    explanation runs and another process of the pool idles, the server leaves no
    process behind: its session empties once it exits. Before, the idle process (and
    multiprocessing's resource tracker with it) was left waiting for work for good,
    after a SIGTERM too. Nothing is forced here, so that an orphan would be seen."""
    server = Server(tmp_path, **{**QUIET, "FLOORPLAN_EXPLAIN_PROCESSES": "2"}).start()
    assert server.process is not None
    sid = server.process.pid
    try:
        with httpx.Client(base_url=server.url, timeout=WAIT) as client:
            assert explain(client).status_code == 200
            call = threading.Thread(target=lambda: _quietly(lambda: explain(client, 30)))
            call.start()
            deadline = time.monotonic() + WAIT
            while len(explain_processes(server)) < 2:
                assert time.monotonic() < deadline
                time.sleep(0.1)
            time.sleep(1)  # the 30-s explanation is in its process by now
            server.process.send_signal(how)
            server.process.wait(WAIT)
            call.join(WAIT)
        deadline = time.monotonic() + WAIT
        while left := in_session(sid):
            assert time.monotonic() < deadline, left
            time.sleep(0.2)
    finally:
        if server.process.poll() is None:
            server.stop()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(sid, signal.SIGKILL)  # whatever is left, once the test has failed


def _quietly(call: Callable[[], object]) -> None:
    """`call`, its connection error (the server stopped under it) ignored."""
    with contextlib.suppress(httpx.TransportError):
        call()
