"""The Celery backend, the API node's side of the distributed mode: jobs go to Celery
workers through Redis, and event streams wake when a worker announces new events of
their job."""

from __future__ import annotations

import asyncio
import logging
import os
import socket
import threading
from typing import Any

import redis
import redis.asyncio as aioredis

from floorplan.models.jobs import JobStatus
from floorplan.service.jobs.backend import JobBackend
from floorplan.service.jobs.broker.config import REDIS_CONNECT_TIMEOUT, Keys, make_celery
from floorplan.service.jobs.celery.dispatch import Dispatcher, Reconciler
from floorplan.service.records import Job
from floorplan.service.settings import Settings
from floorplan.service.store import JobStore

log = logging.getLogger("floorplan.distributed")

#: Seconds an event stream waits for an announcement before looking at the store anyway.
EVENT_FALLBACK_POLL = 1.0


class EventSignals:
    """Wakes event streams when a worker announces new events of their job: one Redis
    subscription per API process, shared by every stream."""

    def __init__(self, settings: Settings) -> None:
        self.url = settings.redis_url
        self.channel = Keys(settings.namespace).events
        self._waiters: dict[str, set[asyncio.Event]] = {}
        self._listener: asyncio.Task[None] | None = None

    async def wait(self, job_id: str, timeout: float) -> None:
        if self._listener is None or self._listener.done():
            self._listener = asyncio.create_task(self._listen())
        woken = asyncio.Event()
        self._waiters.setdefault(job_id, set()).add(woken)
        try:
            await asyncio.wait_for(woken.wait(), timeout)
        except TimeoutError:
            pass
        finally:
            waiting = self._waiters.get(job_id)
            if waiting is not None:
                waiting.discard(woken)
                if not waiting:
                    del self._waiters[job_id]

    async def _listen(self) -> None:
        while True:
            client = aioredis.Redis.from_url(self.url,
                                             socket_connect_timeout=REDIS_CONNECT_TIMEOUT)
            try:
                async with client.pubsub(ignore_subscribe_messages=True) as pubsub:
                    await pubsub.subscribe(self.channel)
                    async for message in pubsub.listen():
                        job_id = message["data"].decode(errors="replace")
                        for woken in self._waiters.get(job_id, ()):
                            woken.set()
            except asyncio.CancelledError:
                raise
            except Exception as err:  # Redis away: streams poll meanwhile
                log.debug("event subscription lost: %s", err)
                await asyncio.sleep(1.0)
            finally:
                await client.aclose()

    async def aclose(self) -> None:
        if self._listener is not None:
            self._listener.cancel()
            await asyncio.gather(self._listener, return_exceptions=True)


class CeleryBackend(JobBackend):
    """The API node's side: jobs go to Celery workers through Redis."""

    name = "celery"

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.store = JobStore(settings.store_url, min_free_bytes=settings.min_free_bytes)
        self.celery = make_celery(settings)
        self.dispatcher = Dispatcher(settings, self.celery, self.store)
        identity = f"api@{socket.gethostname()}:{os.getpid()}"
        self.reconciler = Reconciler(settings, self.store, self.dispatcher, identity)
        self.signals = EventSignals(settings)
        self._stopping = threading.Event()

    def start(self) -> None:
        self.reconciler.start(self._stopping)

    def stop(self) -> None:
        self._stopping.set()
        if self.reconciler.thread is not None:
            self.reconciler.thread.join(timeout=5)
        self.celery.close()
        self.dispatcher.redis.close()

    def submitted(self, job: Job) -> None:
        # While the broker is failing, a submission does not wait on it: the job stays
        # undispatched in the store and the reconciler sends it once Redis answers.
        if not self.dispatcher.broker_failing:
            self.dispatcher.send(job.id)

    def cancel(self, job_id: str) -> None:
        self.store.request_cancel(job_id)
        self.dispatcher.cancel(job_id)
        self.dispatcher.announce(job_id)

    def health(self) -> dict[str, Any]:
        try:
            broker = "ok" if self.dispatcher.redis.ping() else "down"
        except redis.RedisError:
            broker = "down"
        # Accepting jobs needs only the store: with the broker down they wait in it.
        unwritable = self.store.unwritable()
        ready = self.store.ping() and self.reconciler.alive and unwritable is None
        workers = 0
        if broker == "ok":
            pattern = f"{self.dispatcher.keys.workers}*"
            workers = sum(1 for _ in self.dispatcher.redis.scan_iter(pattern, count=500))
        return {"ready": ready, "backend": self.name, "broker": broker,
                "store": unwritable or "ok", "workers": workers,
                "running": self.store.count(JobStatus.RUNNING),
                "queued": self.store.count(JobStatus.QUEUED)}

    async def wait_for_events(self, job_id: str, timeout: float) -> None:
        await self.signals.wait(job_id, min(timeout, EVENT_FALLBACK_POLL))

    async def aclose(self) -> None:
        await self.signals.aclose()
