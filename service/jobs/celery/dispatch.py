"""Getting jobs to the workers, on API nodes and workers alike: the `Dispatcher` sends
them and announces events and cancels over Redis; the `Reconciler` sends again what
nobody is working on."""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

import redis
from celery import Celery

from floorplan.service.jobs.broker.config import TASK_NAME, Keys, redis_client
from floorplan.service.settings import Settings
from floorplan.service.store import JobStore

log = logging.getLogger("floorplan.distributed")

#: How often the reconciler deletes finished jobs past their retention (seconds).
PURGE_EVERY = 60.0


class Dispatcher:
    """Sends jobs to the workers and announces events and cancels, never raising: what
    fails to reach Redis is left to the reconciler (sends) or to polling (the rest)."""

    def __init__(self, settings: Settings, celery: Celery, store: JobStore) -> None:
        self.keys = Keys(settings.namespace)
        self.celery = celery
        self.store = store
        self.redis = redis_client(settings)
        self.pause = settings.reconcile_seconds
        self._failed_at = -float("inf")

    @property
    def broker_failing(self) -> bool:
        """A send failed within the last reconciler period."""
        return time.monotonic() - self._failed_at < self.pause

    def send(self, job_id: str) -> bool:
        try:
            self.celery.send_task(TASK_NAME, args=[job_id], queue=self.keys.queue)
        except Exception as err:  # the broker is down: the reconciler sends it later
            self._failed_at = time.monotonic()
            log.warning("job %s not sent to the broker (%s); it will be sent later", job_id, err)
            self.store.mark_dispatched(job_id, False)
            return False
        self.store.mark_dispatched(job_id)
        return True

    def announce(self, job_id: str) -> None:
        self._publish(self.keys.events, job_id)

    def cancel(self, job_id: str) -> None:
        self._publish(self.keys.cancel, job_id)

    def _publish(self, channel: str, job_id: str) -> None:
        try:
            self.redis.publish(channel, job_id)
        except redis.RedisError as err:
            log.debug("not announced on %s: %s", channel, err)


class Reconciler:
    """Finds accepted jobs nobody is working on and sends them again. Safe to run in
    every node at once: each change is a conditional update that one node wins."""

    def __init__(self, settings: Settings, store: JobStore, dispatcher: Dispatcher,
                 identity: str, also: Callable[[], None] | None = None) -> None:
        self.settings = settings
        self.store = store
        self.dispatcher = dispatcher
        self.identity = identity
        self.also = also  # run on every pass too (a worker says it is alive)
        self._last_purge = 0.0
        self.thread: threading.Thread | None = None

    def start(self, stopping: threading.Event) -> None:
        self.thread = threading.Thread(target=self._loop, args=(stopping,), name="reconciler",
                                       daemon=True)
        self.thread.start()

    @property
    def alive(self) -> bool:
        return self.thread is not None and self.thread.is_alive()

    def _loop(self, stopping: threading.Event) -> None:
        try:
            self.resend_queued()
        except Exception as err:  # the store or Redis is away: the passes below go on
            log.warning("reconciler: %s", err)
        while not stopping.is_set():
            try:
                if self.also is not None:
                    self.also()
                self.reconcile()
            except Exception as err:  # the store or Redis is away: try again next time
                log.warning("reconciler: %s", err)
            stopping.wait(self.settings.reconcile_seconds)

    def resend_queued(self) -> None:
        """Once, when a node starts: every queued job goes to the broker again. A worker
        killed with a job's message received but the job not yet claimed (a batch's
        layouts queue by the hundred) holds that message unacknowledged until Redis's
        visibility timeout, twenty minutes and more; the job would wait that long after
        a restart. Duplicates are harmless: the claim is conditional."""
        queued = self.store.queued()
        if queued:
            log.info("sending %d queued jobs again after a start", len(queued))
        for job_id in queued:
            self.dispatcher.send(job_id)

    def reconcile(self) -> None:
        settings, store, send = self.settings, self.store, self.dispatcher.send
        for job_id in store.requeue_stale(settings.lease_seconds, settings.retry_limit):
            log.warning("job %s lost its worker; queued again", job_id)
            self.dispatcher.announce(job_id)
            send(job_id)
        keys = self.dispatcher.keys
        if self.dispatcher.redis.set(keys.broker_epoch, self.identity, nx=True):
            # Redis holds nothing it was sent (it restarted without its data, or is
            # new): every queued job goes to the broker again. Duplicates of jobs it
            # did have are harmless; the claim is conditional.
            queued = store.queued()
            if queued:
                log.warning("the broker lost its queue; sending %d queued jobs again",
                            len(queued))
            for job_id in queued:
                send(job_id)
        for job_id in store.take_undispatched(time.time() - settings.reconcile_seconds):
            send(job_id)
        if time.monotonic() - self._last_purge > PURGE_EVERY:
            self._last_purge = time.monotonic()
            store.purge(time.time() - settings.retention_hours * 3600)
