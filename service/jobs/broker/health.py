"""The workers' container health check: `python -m floorplan.service.jobs.broker.health
[--subdomains]` exits 0 while a worker process (a sub-domain worker) of this host says it
is alive, else 1. `floorplan worker --health` runs the same check.

A check runs every few seconds inside the worker's container, beside its solves, under
a timeout: on a busy machine even importing the Redis client and the settings (about
0.4 s of CPU) pushed it past 5 s. So it imports the standard library only, speaks the
few Redis commands it needs itself, and run as a module reads its two settings
(FLOORPLAN_REDIS_URL, FLOORPLAN_NAMESPACE) from the environment, a container's only
source of settings; their defaults are the settings' own (a test checks that)."""

from __future__ import annotations

import os
import socket
import sys
from typing import Any
from urllib.parse import unquote, urlsplit

#: Settings.redis_url's and Settings.namespace's defaults.
DEFAULT_REDIS_URL = "redis://127.0.0.1:6379/0"
DEFAULT_NAMESPACE = "floorplan"
#: Seconds to connect and for each reply.
TIMEOUT = 3.0


class RedisError(Exception):
    """Redis answered with an error (a wrong password, an unknown command)."""


def _send(sock: socket.socket, *args: str) -> None:
    parts = [f"*{len(args)}\r\n".encode()]
    for arg in args:
        data = arg.encode()
        parts.append(b"$%d\r\n%s\r\n" % (len(data), data))
    sock.sendall(b"".join(parts))


def _reply(stream: Any) -> Any:
    """One reply of the Redis protocol (RESP2), read from the socket's file."""
    line = stream.readline()
    if not line.endswith(b"\r\n"):
        raise ConnectionError("Redis closed the connection")
    kind, body = line[:1], line[1:-2]
    if kind == b"+":
        return body
    if kind == b"-":
        raise RedisError(body.decode(errors="replace"))
    if kind == b":":
        return int(body)
    if kind == b"$":
        size = int(body)
        return None if size < 0 else stream.read(size + 2)[:-2]
    if kind == b"*":
        return [_reply(stream) for _ in range(int(body))]
    raise ConnectionError(f"not a Redis reply: {line[:40]!r}")


def worker_alive(redis_url: str, namespace: str, host: str | None = None, *,
                 subdomains: bool = False) -> bool:
    """Whether a worker process (a sub-domain worker with `subdomains`) of `host` (this
    one by default) said lately that it is alive: the key it renews (config.py,
    `Keys.workers` / `Keys.subdomain_workers`) exists. Any failure to ask is `False`."""
    url = urlsplit(redis_url)
    prefix = f"{namespace}:subworker:" if subdomains else f"{namespace}:worker:"
    pattern = f"{prefix}{host or socket.gethostname()}:*"
    try:
        sock = socket.create_connection((url.hostname or "127.0.0.1", url.port or 6379),
                                        timeout=TIMEOUT)
        if url.scheme == "rediss":
            import ssl

            sock = ssl.create_default_context().wrap_socket(sock, server_hostname=url.hostname)
        with sock, sock.makefile("rb") as stream:
            if url.password is not None:
                auth = [unquote(url.username)] if url.username else []
                _send(sock, "AUTH", *auth, unquote(url.password))
                _reply(stream)
            db = url.path.strip("/") or "0"
            if db != "0":
                _send(sock, "SELECT", db)
                _reply(stream)
            cursor = "0"
            while True:
                _send(sock, "SCAN", cursor, "MATCH", pattern, "COUNT", "500")
                cursor_bytes, keys = _reply(stream)
                if keys:
                    return True
                cursor = cursor_bytes.decode()
                if cursor == "0":
                    return False
    except (OSError, RedisError, ValueError):
        return False


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if set(args) - {"--subdomains"}:
        print("usage: python -m floorplan.service.jobs.broker.health [--subdomains]",
              file=sys.stderr)
        return 2
    alive = worker_alive(os.environ.get("FLOORPLAN_REDIS_URL", DEFAULT_REDIS_URL),
                         os.environ.get("FLOORPLAN_NAMESPACE", DEFAULT_NAMESPACE),
                         subdomains="--subdomains" in args)
    return 0 if alive else 1


if __name__ == "__main__":
    sys.exit(main())
