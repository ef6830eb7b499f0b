"""The Celery configuration and the Redis names of one deployment, shared by the API
nodes, the workers and the solves that send their sub-domains out."""

from __future__ import annotations

from typing import Any

import redis
from celery import Celery

from floorplan.service.settings import Settings

TASK_NAME = "floorplan.solve"
SUBDOMAIN_TASK = "floorplan.subdomain"
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


def celery_config(settings: Settings) -> dict[str, Any]:
    # The longest a task can legitimately stay unacknowledged; past it the broker
    # redelivers (harmless: the claim is conditional), but the reconciler's lease is
    # what brings a lost job back promptly.
    longest_job = 10 + settings.max_time_limit + 2 * settings.grace_seconds
    return {
        "broker_url": settings.redis_url,
        # JSON only, both ways: a message or a result in another format (pickle runs
        # code as it loads) is refused, whoever put it in Redis.
        "task_serializer": "json",
        "result_serializer": "json",
        "accept_content": ["json"],
        "result_accept_content": ["json"],
        "task_default_queue": settings.namespace,
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,
        "task_ignore_result": True,
        "worker_prefetch_multiplier": 1,
        "worker_pool": "threads",
        "worker_concurrency": settings.workers,
        "worker_cancel_long_running_tasks_on_connection_loss": False,
        "broker_connection_retry_on_startup": True,
        "broker_connection_max_retries": None,
        "broker_transport_options": {
            "global_keyprefix": f"{settings.namespace}:",
            "visibility_timeout": 2 * longest_job + 60,
            "socket_connect_timeout": REDIS_CONNECT_TIMEOUT,
        },
        # Sending fails fast when Redis is down: the job is already accepted and the
        # reconciler sends it once Redis answers again.
        "task_publish_retry_policy": {"max_retries": 2, "interval_start": 0,
                                      "interval_step": 0.2, "interval_max": 0.5},
        # Only sub-domain tasks keep results (jobs keep theirs in the store).
        "result_backend": settings.redis_url,
        "result_backend_transport_options": {"global_keyprefix": f"{settings.namespace}:"},
        "result_expires": 3600,
        "task_routes": {SUBDOMAIN_TASK: {"queue": Keys(settings.namespace).subdomains}},
    }


def make_celery(settings: Settings) -> Celery:
    celery = Celery("floorplan", set_as_current=False)
    celery.conf.update(celery_config(settings))
    return celery


def redis_client(settings: Settings) -> redis.Redis:
    return redis.Redis.from_url(settings.redis_url, socket_connect_timeout=REDIS_CONNECT_TIMEOUT,
                                socket_timeout=10, health_check_interval=10)
