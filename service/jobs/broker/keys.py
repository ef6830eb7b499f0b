"""The Redis names of one deployment, apart from the Celery configuration so that the
health check (health.py) reads them without importing Celery."""

from __future__ import annotations

#: Seconds a Redis connection attempt may take before the broker counts as down.
REDIS_CONNECT_TIMEOUT = 3.0


class Keys:
    """The Redis names of one deployment (FLOORPLAN_NAMESPACE): one Redis can serve
    several deployments, or test sessions, without them seeing each other."""

    def __init__(self, namespace: str) -> None:
        self.queue = namespace
        self.cancel = f"{namespace}:cancel"
        self.events = f"{namespace}:events"
        #: Present while Redis still has what it was sent: missing means a fresh or
        #: restarted Redis, whose queue must be filled again from the store.
        self.broker_epoch = f"{namespace}:broker-epoch"
        #: One key per live worker process, expiring unless renewed (for /readyz).
        self.workers = f"{namespace}:worker:"
        #: The queue of sub-domain tasks, and the keys of the workers consuming it
        #: (each holds the worker's concurrency: the solver plans waves by it).
        self.subdomains = f"{namespace}.subdomains"
        self.subdomain_workers = f"{namespace}:subworker:"
