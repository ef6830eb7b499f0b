"""A solve's independent sub-domains as Celery tasks for the sub-domain workers: the
`concurrent.futures.Executor` the solver takes (`CelerySubdomains`), and how a task's
argument and result travel: as JSON text written and read field by field (codec.py),
never pickled, so that whoever can write to Redis can send a worker data, not code. The
solve's own process imports this (service/jobs/child.py), so it imports nothing of the
backends, the runner or the child."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import Executor, Future
from typing import Any

import redis

from floorplan.service.jobs.broker.config import SUBDOMAIN_TASK, Keys, make_celery, redis_client
from floorplan.service.settings import Settings

log = logging.getLogger("floorplan.distributed")

#: Seconds a sub-domain task may run past its budget before Celery kills its process.
SUBDOMAIN_GRACE = 5.0
#: How often the executor looks for finished sub-domain tasks (seconds).
SUBDOMAIN_POLL = 0.05


class CelerySubdomains(Executor):
    """The solver's sub-domains as Celery tasks on the sub-domain workers. `slots` is
    how many they solve at once, summed over the live ones when this was made."""

    def __init__(self, settings: Settings) -> None:
        self.celery = make_celery(settings)
        self.keys = Keys(settings.namespace)
        client = redis_client(settings)
        try:
            pattern = f"{self.keys.subdomain_workers}*"
            self.slots = sum(int(value or 0) for value in (
                client.get(key) for key in client.scan_iter(pattern, count=500)))
        finally:
            client.close()
        self._pending: dict[str, tuple[Any, Future[Any]]] = {}
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._poller: threading.Thread | None = None

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        from floorplan.service.jobs.broker.codec import encode_task
        from floorplan.solver.pipeline.subdomains import SubdomainTask, solve_subdomain

        (task,) = args
        if fn is not solve_subdomain or kwargs or not isinstance(task, SubdomainTask):
            raise ValueError("only solver.pipeline.subdomains.solve_subdomain(task) runs remotely")
        future: Future[Any] = Future()
        result = self.celery.send_task(
            SUBDOMAIN_TASK, args=[encode_task(task)], queue=self.keys.subdomains,
            time_limit=task.budget + SUBDOMAIN_GRACE,
            expires=max(1.0, task.deadline - time.time()),  # useless once the level is over
        )
        with self._lock:
            self._pending[result.id] = (result, future)
            if self._poller is None:
                self._poller = threading.Thread(target=self._poll, name="subdomain-results",
                                                daemon=True)
                self._poller.start()
        return future

    def _poll(self) -> None:
        from floorplan.service.jobs.broker.codec import decode_outcome

        while not self._closed.is_set():
            with self._lock:
                pending = list(self._pending.items())
            for task_id, (result, future) in pending:
                try:
                    if future.cancelled():
                        done = True
                    elif done := result.ready():
                        future.set_result(decode_outcome(result.get(timeout=5)))
                except Exception as err:  # the task failed or its process was killed
                    done = True
                    future.set_exception(err)
                if done:
                    with self._lock:
                        self._pending.pop(task_id, None)
            self._closed.wait(SUBDOMAIN_POLL)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._closed.set()
        self.celery.close()


def subdomain_executor(settings: Settings) -> CelerySubdomains | None:
    """A `CelerySubdomains` when sub-domain workers are alive, else None (the solve
    then uses its local pool, or goes one sub-domain after the other)."""
    try:
        executor = CelerySubdomains(settings)
    except redis.RedisError as err:
        log.warning("no sub-domain workers (%s): sub-domains solved locally", err)
        return None
    if executor.slots < 1:
        executor.shutdown()
        return None
    return executor
