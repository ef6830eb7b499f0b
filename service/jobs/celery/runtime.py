"""What a worker process holds besides Celery's pool: a job worker, the store, its
warmed-up solve processes, the jobs it runs, its cancel subscription and its reconciler
(`WorkerRuntime`); a sub-domain worker, its liveness key (`SubdomainWorkerRuntime`)."""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import threading
import uuid

import redis
from celery import Celery
from celery.exceptions import Reject
from sqlalchemy.exc import DataError, IntegrityError, ProgrammingError

from floorplan.models.jobs import JobStatus
from floorplan.service.jobs.broker.config import Keys, redis_client
from floorplan.service.jobs.celery.dispatch import Dispatcher, Reconciler
from floorplan.service.jobs.processes import Child, Lease, SolveProcesses, watch
from floorplan.service.settings import Settings
from floorplan.service.store import JobStore

log = logging.getLogger("floorplan.distributed")

#: Seconds a worker waits before handing back a task it could not claim (the store
#: did not answer), so that a store outage is not a busy loop.
CLAIM_RETRY_SECONDS = 2.0
#: Times one message is handed back to the broker (the store away) before it is
#: dropped: a job it named is still in the store, and the reconciler sends it again.
MAX_REDELIVERIES = 10
#: What the store raises about the message's data, not about the store's state: such a
#: message fails the same way every time, so it is dropped, never handed back.
DATA_ERRORS = (DataError, IntegrityError, ProgrammingError)


def job_id_of(value: object) -> str | None:
    """`value` as a job id (a UUID in its canonical text), or None: whoever can write
    to Redis can send anything, and a message that names no job is dropped at the door."""
    if not isinstance(value, str) or len(value) != 36:
        return None
    try:
        canonical = str(uuid.UUID(value))
    except ValueError:
        return None
    return canonical if canonical == value.lower() else None


class WorkerRuntime:
    """What one worker process holds: the store, warmed-up solve processes, the jobs it
    runs, its cancel subscription and its reconciler."""

    def __init__(self, settings: Settings, celery: Celery) -> None:
        self.settings = settings
        self.store = JobStore(settings.store_url, min_free_bytes=settings.min_free_bytes)
        self.dispatcher = Dispatcher(settings, celery, self.store)
        self.identity = f"{socket.gethostname()}:{os.getpid()}"
        self.reconciler = Reconciler(settings, self.store, self.dispatcher, self.identity,
                                     also=self._say_alive)
        self.processes = SolveProcesses(settings.subdomain_processes_per_solve,
                                        subdomain_tasks=settings.subdomains == "celery")
        self.stopping = threading.Event()
        #: Solves at once: Celery's concurrency (FLOORPLAN_WORKERS unless `-c` says).
        self.slots = settings.workers
        self._active: dict[str, Child] = {}
        self._lock = threading.Lock()

    def start(self, slots: int | None = None) -> None:
        self.slots = slots or self.slots
        self.processes.refill(self.slots)
        threading.Thread(target=self._listen_for_cancels, name="cancels", daemon=True).start()
        self.reconciler.start(self.stopping)
        log.info("worker %s ready: %d solves at once", self.identity, self.slots)

    def shutdown(self) -> None:
        """A graceful stop: the running solves are killed and their jobs handed back
        (the task threads do that as their watch ends)."""
        self.stopping.set()
        self.processes.close()
        with contextlib.suppress(redis.RedisError):  # else it expires
            self.dispatcher.redis.delete(self.dispatcher.keys.workers + self.identity)

    def _say_alive(self) -> None:
        with self._lock:
            busy = len(self._active)
        ttl = max(self.settings.lease_seconds, 3 * self.settings.reconcile_seconds)
        self.dispatcher.redis.set(self.dispatcher.keys.workers + self.identity,
                                  f"{busy}/{self.slots}", ex=max(1, round(ttl)))

    def run(self, value: object, message_id: str | None = None) -> str:
        """The task: `value` names a queued job; claim the next job fairly across keys
        (that one, or another key's waiting longer) and solve it. Returns what happened,
        for the log. A message that names no job, or whose data the store refuses, is
        acknowledged and dropped with a log line; one handed back too often (the store
        away) too."""
        job_id = job_id_of(value)
        if job_id is None:
            log.warning("dropped a message that names no job: %.80r", value)
            return "dropped"
        if self.stopping.is_set():
            raise Reject("the worker is stopping", requeue=True)  # for another worker
        token = f"{self.identity}:{uuid.uuid4().hex[:8]}"
        try:
            # The message says a job waits; the job run is the fairest one across keys
            # (docs/security.md, "Fair scheduling"), not necessarily the one it names.
            job = self.store.claim_fair(job_id, token)
        except DATA_ERRORS as err:
            log.warning("dropped the message of job %s: the store refuses its data (%s)",
                        job_id, type(err).__name__)
            return "dropped"
        except Exception as err:
            if self._handed_back(message_id) > MAX_REDELIVERIES:
                log.warning("dropped the message of job %s: handed back %d times (%s); the "
                            "reconciler sends the job again", job_id, MAX_REDELIVERIES, err)
                return "dropped"
            # The store is away: the task goes back to the broker, not lost by an ack.
            log.warning("job %s not claimed (%s); handed back to the broker", job_id, err)
            self.stopping.wait(CLAIM_RETRY_SECONDS)
            raise Reject(str(err), requeue=True) from err
        if job is None:
            return "not queued"  # a duplicate delivery, a canceled or finished job
        job_id = job.id
        log.info("job %s claimed as %s (attempt %d, limit %g s)", job_id, token, job.attempts,
                 job.time_limit)
        self.dispatcher.announce(job_id)
        child = self.processes.take()
        with self._lock:
            self._active[job_id] = child
        try:
            child.start(job.problem)
            how = watch(job, child, self.store, self.settings, stopping=self.stopping,
                        lease=Lease(token, self.settings.heartbeat_seconds),
                        notify=self.dispatcher.announce)
            if how == "stopping" and self.store.hand_back(job_id, worker=token):
                self.dispatcher.announce(job_id)
                self.dispatcher.send(job_id)
            log.info("job %s: %s", job_id, {"finished": "ended", "stopping": "handed back",
                                             "lost": "lost its lease"}.get(how, how))
            return how
        except Exception:
            log.exception("job %s failed in the worker", job_id)
            child.process.kill()
            self.store.finish(job_id, JobStatus.FAILED, worker=token,
                              error={"code": "internal", "message": "the worker lost this job"})
            self.dispatcher.announce(job_id)
            return "failed"
        finally:
            with self._lock:
                self._active.pop(job_id, None)
                busy = len(self._active)
            if not self.stopping.is_set():
                self.processes.refill(self.slots - busy)

    def _handed_back(self, message_id: str | None) -> int:
        """How many times the message `message_id` was handed back, this one included
        (counted in Redis, across workers; 0 when it cannot be counted)."""
        if not message_id:
            return 0
        key = f"{self.dispatcher.keys.queue}:handed-back:{message_id}"
        try:
            count = int(self.dispatcher.redis.incr(key))
            self.dispatcher.redis.expire(key, 3600)
        except redis.RedisError:
            return 0
        return count

    def _listen_for_cancels(self) -> None:
        channel = self.dispatcher.keys.cancel
        while not self.stopping.is_set():
            try:
                with self.dispatcher.redis.pubsub(ignore_subscribe_messages=True) as pubsub:
                    pubsub.subscribe(channel)
                    while not self.stopping.is_set():
                        message = pubsub.get_message(timeout=1.0)
                        if message is None:
                            continue
                        with self._lock:
                            child = self._active.get(message["data"].decode(errors="replace"))
                        if child is not None:
                            child.stop.set()
            except redis.RedisError as err:  # the lease heartbeat reads cancels meanwhile
                log.debug("cancel subscription lost: %s", err)
                self.stopping.wait(1.0)


class SubdomainWorkerRuntime:
    """What a sub-domain worker holds besides Celery's pool: its liveness key."""

    def __init__(self, settings: Settings, slots: int) -> None:
        self.settings = settings
        self.keys = Keys(settings.namespace)
        self.redis = redis_client(settings)
        self.key = f"{self.keys.subdomain_workers}{socket.gethostname()}:{os.getpid()}"
        self.slots = slots
        self.stopping = threading.Event()

    def start(self) -> None:
        threading.Thread(target=self._say_alive, name="alive", daemon=True).start()
        log.info("sub-domain worker %s ready: %d at once", self.key, self.slots)

    def shutdown(self) -> None:
        self.stopping.set()
        with contextlib.suppress(redis.RedisError):
            self.redis.delete(self.key)

    def _say_alive(self) -> None:
        ttl = max(1, round(max(self.settings.lease_seconds, 3 * self.settings.reconcile_seconds)))
        while not self.stopping.is_set():
            try:
                self.redis.set(self.key, self.slots, ex=ttl)
            except redis.RedisError as err:
                log.debug("liveness not renewed: %s", err)
            self.stopping.wait(self.settings.reconcile_seconds)
