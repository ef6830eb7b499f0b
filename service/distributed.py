"""The distributed mode: API nodes and Celery workers, Redis as broker and pub/sub, job
records in PostgreSQL (or any store URL; the schema is the embedded store's).

A job's life here:

- An API node commits the job (it is accepted: 202), then sends a Celery task naming
  it and marks it dispatched. If the broker is down, the job stays undispatched and the
  reconciler sends it later.
- A worker receives the task, claims the job in the store (a conditional update: a
  duplicate delivery finds it no longer queued and does nothing), and solves it in a
  spawned child process under the same watchdog as the embedded mode
  (`service.runner.watch`). Tasks are acknowledged late, after the job ended.
- While solving, the worker renews its lease on the job every few seconds and reads
  the job's cancel flag; a cancel also arrives at once over Redis pub/sub. Every event
  it writes is announced on a Redis channel, on which API nodes wake their event
  streams (they poll the store as well, so a lost announcement only delays).
- The reconciler, a thread in every API node and worker, puts back in the queue the
  running jobs whose lease expired (their worker died: SIGKILL, power, partition) and
  sends again the queued jobs the broker does not have: never sent, or lost when Redis
  restarted without its data (a marker key tells: Redis lost it too).
- A worker stopped gracefully (SIGTERM) kills its solves and hands their jobs back to
  the queue at once, without counting an attempt.

Workers use Celery's `threads` pool: the solve runs in its own process anyway, and a
thread that watches it keeps the worker light.

With FLOORPLAN_SUBDOMAINS=celery, the independent sub-domains of a refinement level go
out as Celery tasks (`CelerySubdomains`, a `concurrent.futures.Executor` the solver
takes) to sub-domain workers (`floorplan worker --subdomains`), which consume a queue of
their own with Celery's prefork pool: each sub-domain is solved in a pool process under
Celery's hard time limit. Their results come back through Celery's Redis result backend.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import logging
import os
import pickle
import socket
import threading
import time
import uuid
from collections.abc import Callable
from concurrent.futures import Executor, Future
from typing import Any

import redis
import redis.asyncio as aioredis
from celery import Celery, signals
from celery.exceptions import Reject

from service.backends import JobBackend
from service.runner import Child, Lease, SolveProcesses, watch
from service.settings import Settings, get_settings
from service.store import Job, JobStatus, JobStore

log = logging.getLogger("floorplan.distributed")

TASK_NAME = "floorplan.solve"
SUBDOMAIN_TASK = "floorplan.subdomain"
#: Seconds a sub-domain task may run past its budget before Celery kills its process.
SUBDOMAIN_GRACE = 5.0
#: How often the executor looks for finished sub-domain tasks (seconds).
SUBDOMAIN_POLL = 0.05
#: Seconds a Redis connection attempt may take before the broker counts as down.
REDIS_CONNECT_TIMEOUT = 3.0
#: Seconds an event stream waits for an announcement before looking at the store anyway.
EVENT_FALLBACK_POLL = 1.0
#: How often the reconciler deletes finished jobs past their retention (seconds).
PURGE_EVERY = 60.0
#: Seconds a worker waits before handing back a task it could not claim (the store
#: did not answer), so that a store outage is not a busy loop.
CLAIM_RETRY_SECONDS = 2.0


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
        while not stopping.is_set():
            try:
                if self.also is not None:
                    self.also()
                self.reconcile()
            except Exception as err:  # the store or Redis is away: try again next time
                log.warning("reconciler: %s", err)
            stopping.wait(self.settings.reconcile_seconds)

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


# The API's side.


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
        self.store = JobStore(settings.store_url)
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
        ready = self.store.ping() and self.reconciler.alive
        workers = 0
        if broker == "ok":
            pattern = f"{self.dispatcher.keys.workers}*"
            workers = sum(1 for _ in self.dispatcher.redis.scan_iter(pattern, count=500))
        return {"ready": ready, "backend": self.name, "broker": broker, "workers": workers,
                "running": self.store.count(JobStatus.RUNNING),
                "queued": self.store.count(JobStatus.QUEUED)}

    async def wait_for_events(self, job_id: str, timeout: float) -> None:
        await self.signals.wait(job_id, min(timeout, EVENT_FALLBACK_POLL))

    async def aclose(self) -> None:
        await self.signals.aclose()


# The worker's side.


class WorkerRuntime:
    """What one worker process holds: the store, warmed-up solve processes, the jobs it
    runs, its cancel subscription and its reconciler."""

    def __init__(self, settings: Settings, celery: Celery) -> None:
        self.settings = settings
        self.store = JobStore(settings.store_url)
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

    def run(self, job_id: str) -> str:
        """The task: claim `job_id` and solve it. Returns what happened, for the log."""
        if self.stopping.is_set():
            raise Reject("the worker is stopping", requeue=True)  # for another worker
        token = f"{self.identity}:{uuid.uuid4().hex[:8]}"
        try:
            job = self.store.claim(job_id, token)
        except Exception as err:
            # The store is away: the task goes back to the broker, not lost by an ack.
            log.warning("job %s not claimed (%s); handed back to the broker", job_id, err)
            self.stopping.wait(CLAIM_RETRY_SECONDS)
            raise Reject(str(err), requeue=True) from err
        if job is None:
            return "not queued"  # a duplicate delivery, a canceled or finished job
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


# Sub-domains as Celery tasks.


def pack(value: Any) -> str:
    """Pickled for a task argument or result: sub-domain specs are plain dataclasses, and
    the broker is as trusted as the database."""
    return base64.b64encode(pickle.dumps(value)).decode()


def unpack(text: str) -> Any:
    return pickle.loads(base64.b64decode(text))


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
        from solver.pipeline.subdomains import SubdomainTask, solve_subdomain

        (task,) = args
        if fn is not solve_subdomain or kwargs or not isinstance(task, SubdomainTask):
            raise ValueError("only solver.pipeline.subdomains.solve_subdomain(task) runs remotely")
        future: Future[Any] = Future()
        result = self.celery.send_task(
            SUBDOMAIN_TASK, args=[pack(task)], queue=self.keys.subdomains,
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
        while not self._closed.is_set():
            with self._lock:
                pending = list(self._pending.items())
            for task_id, (result, future) in pending:
                try:
                    if future.cancelled():
                        done = True
                    elif done := result.ready():
                        future.set_result(unpack(result.get(timeout=5)))
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


# The Celery application that `celery -A service.distributed worker` and
# `floorplan worker` run; settings from the environment, or from `configure`.

app = make_celery(get_settings())
_worker_settings: Settings = get_settings()
_runtime: WorkerRuntime | None = None
_subdomain_runtime: SubdomainWorkerRuntime | None = None


def configure(settings: Settings) -> None:
    """Use `settings` (e.g. with command-line overrides) for this process's worker."""
    global _worker_settings
    _worker_settings = settings
    app.conf.update(celery_config(settings))


def runtime() -> WorkerRuntime:
    global _runtime
    if _runtime is None:
        _runtime = WorkerRuntime(_worker_settings, app)
    return _runtime


@app.task(name=TASK_NAME)
def solve_job(job_id: str) -> str:
    return runtime().run(job_id)


@app.task(name=SUBDOMAIN_TASK, ignore_result=False, acks_late=False)
def solve_subdomain_task(payload: str) -> str:
    """One sub-domain, in a process of a sub-domain worker's prefork pool. Not acked
    late: a sub-domain whose worker died is not worth solving after its level ended."""
    from solver.pipeline.subdomains import solve_subdomain

    return pack(solve_subdomain(unpack(payload)))


@signals.worker_ready.connect
def _on_worker_ready(sender: Any = None, **_: Any) -> None:
    global _subdomain_runtime
    concurrency = getattr(getattr(sender, "controller", None), "concurrency", None)
    slots = concurrency if isinstance(concurrency, int) else None
    consumed = getattr(getattr(sender, "app", app).amqp.queues, "consume_from", None) or {}
    keys = Keys(_worker_settings.namespace)
    if keys.subdomains in consumed and keys.queue not in consumed:
        _subdomain_runtime = SubdomainWorkerRuntime(_worker_settings,
                                                    slots or _worker_settings.workers)
        _subdomain_runtime.start()
        return
    runtime().start(slots)


@signals.worker_shutting_down.connect
def _on_worker_shutting_down(**_: Any) -> None:
    if _runtime is not None:
        _runtime.shutdown()
    if _subdomain_runtime is not None:
        _subdomain_runtime.shutdown()


def worker_alive(settings: Settings, host: str | None = None, *,
                 subdomains: bool = False) -> bool:
    """Whether a worker process (a sub-domain worker with `subdomains`) of `host` (this
    one by default) said lately that it is alive: the key it renews exists."""
    keys = Keys(settings.namespace)
    client = redis_client(settings)
    try:
        prefix = keys.subdomain_workers if subdomains else keys.workers
        pattern = f"{prefix}{host or socket.gethostname()}:*"
        return next(iter(client.scan_iter(pattern, count=500)), None) is not None
    except redis.RedisError:
        return False
    finally:
        client.close()


def run_worker(settings: Settings, *, hostname: str | None = None,
               loglevel: str = "INFO", subdomains: bool = False) -> int:
    """`floorplan worker`: a Celery worker of this application; with `subdomains`, one
    that solves sub-domains (prefork: each in a pool process, under a hard time limit)."""
    configure(settings)
    queue = Keys(settings.namespace).subdomains if subdomains else settings.namespace
    argv = ["worker", f"--loglevel={loglevel}", f"--queues={queue}",
            # Gossip, mingle and Celery's own heartbeats serve remote control and
            # monitoring; the store's leases do that job here, and startup is faster.
            "--without-gossip", "--without-mingle", "--without-heartbeat"]
    if hostname:
        argv.append(f"--hostname={hostname}")
    if subdomains:
        argv.append("--pool=prefork")
    app.worker_main(argv)
    return 0

