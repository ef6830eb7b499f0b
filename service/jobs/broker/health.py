"""The workers' container health check: `python -m floorplan.service.jobs.broker.health
[--subdomains]` exits 0 while a worker process (a sub-domain worker) of this host says it
is alive, else 1. It imports the settings and the Redis client only, not Celery or the
solver: a check runs every few seconds beside the solves and must answer in well under
its timeout on a busy machine. `floorplan worker --health` runs the same check."""

from __future__ import annotations

import socket
import sys

import redis

from floorplan.service.jobs.broker.keys import REDIS_CONNECT_TIMEOUT, Keys
from floorplan.service.settings import Settings


def worker_alive(settings: Settings, host: str | None = None, *,
                 subdomains: bool = False) -> bool:
    """Whether a worker process (a sub-domain worker with `subdomains`) of `host` (this
    one by default) said lately that it is alive: the key it renews exists."""
    keys = Keys(settings.namespace)
    client = redis.Redis.from_url(settings.redis_url, socket_connect_timeout=REDIS_CONNECT_TIMEOUT,
                                  socket_timeout=REDIS_CONNECT_TIMEOUT)
    try:
        prefix = keys.subdomain_workers if subdomains else keys.workers
        pattern = f"{prefix}{host or socket.gethostname()}:*"
        return next(iter(client.scan_iter(pattern, count=500)), None) is not None
    except redis.RedisError:
        return False
    finally:
        client.close()


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if set(args) - {"--subdomains"}:
        print("usage: python -m floorplan.service.jobs.broker.health [--subdomains]",
              file=sys.stderr)
        return 2
    return 0 if worker_alive(Settings(), subdomains="--subdomains" in args) else 1


if __name__ == "__main__":
    sys.exit(main())
