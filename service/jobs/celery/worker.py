"""The Celery application that `celery -A floorplan.service.jobs.celery.worker worker` and
`floorplan worker` run: its two tasks, the signals that start and stop a worker's
runtime, and for the command line `run_worker` (the health check is broker/health.py,
which does not import Celery). Settings come from
the environment, or from `configure`."""

from __future__ import annotations

from typing import Any

from celery import signals

from floorplan.service.jobs.broker.config import (
    SUBDOMAIN_TASK,
    TASK_NAME,
    Keys,
    celery_config,
    make_celery,
)
from floorplan.service.jobs.celery.runtime import SubdomainWorkerRuntime, WorkerRuntime
from floorplan.service.settings import Settings, get_settings

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
    late: a sub-domain whose worker died is not worth solving after its level ended.
    The payload is JSON read field by field: anything else fails here (CodecError)."""
    from floorplan.service.jobs.broker.codec import decode_task, encode_outcome
    from floorplan.solver.pipeline.subdomains import solve_subdomain

    return encode_outcome(solve_subdomain(decode_task(payload)))


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
