"""Request bodies on every body route (/v1/layouts, /v1/validate, /v1/batches) are read
by one reader: the key checked from the headers first, the declared size against
FLOORPLAN_MAX_BODY_BYTES before a byte is read, a streamed body cut at the limit, and
the parsing off the event loop. Attacked as a client would, over raw sockets to real
server processes on loopback (tests/servers.py)."""

from __future__ import annotations

import json
import socket
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from tests.servers import Server
from tests.service.test_service import SMALL

#: One solve at a time and no sub-domain pool: these tests solve nothing.
QUIET = {"WORKERS": "1", "FLOORPLAN_SUBDOMAIN_PROCESSES": "1"}
KEY = "alpha"
ROUTES = ["/v1/layouts", "/v1/validate", "/v1/batches"]
MB = 1 << 20
#: The body the review sent to POST /v1/batches: 100 MB.
HUGE = 100 * MB
#: How long a refusal may take at most: a bounded wait, far above what a refusal
#: before reading takes, far below what reading 100 MB took (17 s).
ANSWER_WAIT = 60


@pytest.fixture(scope="module")
def keyed(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    server = Server(tmp_path_factory.mktemp("keyed"), FLOORPLAN_API_KEYS=KEY, **QUIET).start()
    yield server
    server.stop()


@pytest.fixture(scope="module")
def open_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    server = Server(tmp_path_factory.mktemp("open"), **QUIET).start()
    yield server
    server.stop()


@dataclass
class Upload:
    """A request sent over a raw socket: its headers at once, then `size` bytes of body
    in 1 MB chunks from a thread, for as long as the server takes them."""

    server: Server
    path: str
    size: int
    headers: dict[str, str]
    chunked: bool = False
    sent: int = 0
    status: int | None = None
    answer: bytes = b""
    elapsed: float = 0.0
    _sock: socket.socket = field(init=False)

    def run(self) -> Upload:
        started = time.monotonic()
        self._sock = socket.create_connection(("127.0.0.1", self.server.port))
        self._sock.settimeout(ANSWER_WAIT)
        head = [f"POST {self.path} HTTP/1.1", f"Host: 127.0.0.1:{self.server.port}",
                "Content-Type: application/json"]
        head.append("Transfer-Encoding: chunked" if self.chunked
                    else f"Content-Length: {self.size}")
        head += [f"{k}: {v}" for k, v in self.headers.items()]
        self._sock.sendall(("\r\n".join(head) + "\r\n\r\n").encode())
        sender = threading.Thread(target=self._send_body, daemon=True)
        sender.start()
        try:
            while b"\r\n\r\n" not in self.answer:
                chunk = self._sock.recv(65536)
                if not chunk:
                    break
                self.answer += chunk
        finally:
            self.elapsed = time.monotonic() - started
            self._sock.close()
            sender.join(ANSWER_WAIT)
        self.status = int(self.answer.split(b" ", 2)[1]) if self.answer else None
        return self

    def _send_body(self) -> None:
        # A JSON string of spaces: valid JSON all along, were it read to its end.
        piece = b"[" + b" " * (MB - 2) + b"]" if not self.chunked else b" " * MB
        try:
            while self.sent < self.size:
                data = piece[: self.size - self.sent]
                if self.chunked:
                    data = f"{len(data):x}\r\n".encode() + data + b"\r\n"
                self._sock.sendall(data)
                self.sent += len(piece[: self.size - self.sent])
        except OSError:
            pass  # the server closed the connection: the rest was never going to be read


def rss(server: Server) -> int:
    """The server process's resident memory, bytes."""
    assert server.process is not None
    status = Path(f"/proc/{server.process.pid}/status").read_text()
    line = next(line for line in status.splitlines() if line.startswith("VmRSS:"))
    return int(line.split()[1]) * 1024


@pytest.mark.parametrize("path", ROUTES)
def test_an_unauthenticated_body_is_refused_before_it_is_read(keyed: Server, path: str) -> None:
    upload = Upload(keyed, path, HUGE, {}).run()
    assert upload.status == 401, upload.answer[:300]
    # Answered while most of the body was still unsent: the server never waited for it
    # (the sender stops when the socket buffers are full or the server hangs up).
    assert upload.sent < HUGE / 2


@pytest.mark.parametrize("path", ROUTES)
def test_a_declared_size_over_the_limit_is_a_413_before_reading(keyed: Server,
                                                                path: str) -> None:
    upload = Upload(keyed, path, HUGE, {"Authorization": f"Bearer {KEY}"}).run()
    assert upload.status == 413, upload.answer[:300]
    assert b"FLOORPLAN_MAX_BODY_BYTES" in upload.answer or upload.sent < HUGE / 2
    assert upload.sent < HUGE / 2


@pytest.mark.parametrize("path", ROUTES)
def test_a_streamed_body_is_cut_at_the_limit(open_server: Server, path: str) -> None:
    # No Content-Length: the reader counts what arrives and stops at 1 MB (the default).
    upload = Upload(open_server, path, 50 * MB, {}, chunked=True).run()
    assert upload.status == 413, upload.answer[:300]
    assert upload.sent < 25 * MB


def test_four_unauthenticated_100_mb_batches_hold_up_nothing(keyed: Server) -> None:
    """The review's attack: four 100 MB bodies at once on POST /v1/batches without a
    key took 40 s to refuse and 1.2 GB of memory, /healthz over 5 s meanwhile. Now each
    is refused from its headers: the memory stays where it was and /healthz answers."""
    before = rss(keyed)
    uploads = [Upload(keyed, "/v1/batches", HUGE, {}) for _ in range(4)]
    threads = [threading.Thread(target=u.run) for u in uploads]
    slowest = 0.0
    with httpx.Client(base_url=keyed.url, timeout=ANSWER_WAIT) as client:
        for thread in threads:
            thread.start()
        while any(t.is_alive() for t in threads):
            started = time.monotonic()
            assert client.get("/healthz").status_code == 200
            slowest = max(slowest, time.monotonic() - started)
        for thread in threads:
            thread.join()
    assert [u.status for u in uploads] == [401] * 4
    assert all(u.sent < HUGE / 2 for u in uploads)
    # Nothing was buffered: 100 MB read would have shown here four times over.
    assert rss(keyed) - before < 50 * MB
    print(f"refused in {max(u.elapsed for u in uploads):.2f} s at most, "
          f"/healthz {slowest:.3f} s at most")


def big_templated(rooms: int = 400) -> dict[str, Any]:
    """A templated brief of `rooms` rooms whose last room type does not exist: a 422
    once validated."""
    return {"boundary": [[0, 0], [60, 0], [60, 60], [0, 60]], "template": "residential",
            "rooms": ["bedroom"] * (rooms - 1) + ["no-such-type"]}


@pytest.mark.parametrize("path", ROUTES)
def test_the_key_is_checked_before_the_body_is_validated(keyed: Server, path: str) -> None:
    brief = big_templated()
    body = {"problem": brief, "count": 2} if path == "/v1/batches" else brief
    with httpx.Client(base_url=keyed.url, timeout=ANSWER_WAIT) as client:
        refused = client.post(path, json=body)
        assert refused.status_code == 401, refused.text
        assert refused.headers["content-type"] == "application/problem+json"
        # With the key, the same body is what it is: invalid (validate answers 200
        # with the errors listed, the others 422).
        judged = client.post(path, json=body, headers={"Authorization": f"Bearer {KEY}"})
        assert judged.status_code in (200, 422), judged.text
        if judged.status_code == 200:
            assert judged.json()["valid"] is False


def test_a_batch_body_s_errors_are_problem_documents_naming_the_field(
        open_server: Server) -> None:
    with httpx.Client(base_url=open_server.url, timeout=ANSWER_WAIT) as client:
        count = client.post("/v1/batches", json={"problem": SMALL, "count": 0})
        assert count.status_code == 422
        assert count.headers["content-type"] == "application/problem+json"
        assert [e["field"] for e in count.json()["errors"]] == ["count"]
        brief = client.post("/v1/batches", json={"problem": {**SMALL, "rooms": []}, "count": 1})
        assert brief.status_code == 422
        assert all(e["field"].startswith("problem.") for e in brief.json()["errors"])
        not_json = client.post("/v1/batches", content=b"{", headers={
            "Content-Type": "application/json"})
        assert not_json.status_code == 400
        as_text = client.post("/v1/batches", content=json.dumps({"problem": SMALL, "count": 1}),
                              headers={"Content-Type": "text/plain"})
        assert as_text.status_code == 415
