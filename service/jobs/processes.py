"""Runs jobs: each solve in its own spawned process under a watchdog.

`SolveProcesses` keeps warmed-up solve processes ready; `watch` supervises one job's
process and records what it reports; both serve the embedded `Runner` here (at most
`workers` at once, first in first out) and the Celery workers of the distributed mode
(service/jobs/celery/), so a solve runs the same way in either. What runs inside a
solve's process is service/jobs/child.py.

The watchdog enforces the job's time limit plus a grace period: first it sets the
child's stop flag (SCIP is interrupted and the incumbent is returned), then, after
another grace period, it kills the child. A child that dies (segfault, out of
memory, kill) fails its own job with the reason; the service carries on.
"""

from __future__ import annotations

import json
import logging
import multiprocessing
import os
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from multiprocessing.synchronize import Event
from typing import Any

from service.jobs.child import standby
from service.records import Job, JobStatus
from service.settings import Settings
from service.store import JobStore

log = logging.getLogger("floorplan.runner")

#: Seconds a child may take to start (imports of SCIP, shapely) before its clock runs.
STARTUP_SECONDS = 10.0
#: Progress and incumbent events are written at most this often per job (2 a second).
EVENT_INTERVAL = 0.5
#: How often the runner looks for new work when nobody wakes it (seconds).
POLL_SECONDS = 0.5
#: Tries at recording a job's end when the store does not answer, a second apart.
FINISH_ATTEMPTS = 5
#: Seconds the waiting solve processes get to exit by themselves at shutdown.
CLOSE_SECONDS = 5.0


@dataclass
class Child:
    """A solve process already started and warmed up, waiting for its job."""

    process: Any
    jobs: Any  # the sending end of the pipe its job goes down
    messages: Any
    stop: Event

    def start(self, problem_json: str) -> None:
        self.jobs.send(problem_json)
        self.jobs.close()


class SolveProcesses:
    """Spawned solve processes, one warmed up ahead per idle slot: a job then starts
    without waiting about a second for the imports of SCIP and shapely."""

    def __init__(self, subdomain_processes: int = 1, subdomain_tasks: bool = False) -> None:
        self.subdomain_processes = subdomain_processes
        self.subdomain_tasks = subdomain_tasks
        self._ctx = multiprocessing.get_context("spawn")
        self._ready: list[Child] = []
        self._lock = threading.Lock()

    def take(self) -> Child:
        with self._lock:
            while self._ready:
                ready = self._ready.pop(0)
                if ready.process.is_alive():
                    return ready
        return self._start()

    def refill(self, idle_slots: int) -> None:
        with self._lock:
            self._ready = [c for c in self._ready if c.process.is_alive()]
            missing = idle_slots - len(self._ready)
        for _ in range(missing):
            child = self._start()
            with self._lock:
                self._ready.append(child)

    def close(self) -> None:
        """End the waiting solve processes: told that no job will come, each ends its
        pool and exits (killed ones would leave their pool's semaphores for the
        resource tracker to clean up, with a warning); stragglers are killed."""
        with self._lock:
            ready, self._ready = self._ready, []
        for child in ready:
            child.jobs.close()
        give_up = time.monotonic() + CLOSE_SECONDS
        for child in ready:
            child.process.join(timeout=max(0.0, give_up - time.monotonic()))
            if child.process.is_alive():
                child.process.kill()

    def _start(self) -> Child:
        receive, send = self._ctx.Pipe(duplex=False)
        messages = self._ctx.Queue()
        stop = self._ctx.Event()
        process = self._ctx.Process(target=standby,
                                    args=(receive, messages, stop, os.getpid(),
                                          self.subdomain_processes, self.subdomain_tasks),
                                    name="solve", daemon=True)
        process.start()
        receive.close()
        return Child(process, send, messages, stop)


@dataclass
class Lease:
    """The distributed mode's hold on a job: writes are fenced to `worker`, which renews
    its lease every `every` seconds and learns there whether a cancel was asked for."""

    worker: str
    every: float
    last: float = field(default_factory=time.monotonic)


def watch(
    job: Job, child: Child, store: JobStore, settings: Settings, *,
    stopping: threading.Event, lease: Lease | None = None,
    notify: Callable[[str], None] | None = None,
) -> str:
    """Supervise `job`'s solve in `child` until it ends, recording its progress,
    incumbents and end in the store. `notify(job_id)` is told after each event written.
    Returns how it ended: "finished" (recorded), "stopping" (the service is stopping:
    the caller hands the job back) or "lost" (the lease went to another worker)."""
    process, messages, stop = child.process, child.messages, child.stop
    worker = lease.worker if lease else None
    grace = settings.grace_seconds
    started = time.monotonic()
    interrupt_at = started + STARTUP_SECONDS + job.time_limit + grace
    kill_at = interrupt_at + grace
    pending: dict[str, Any] = {}
    last_flush = 0.0
    outcome: tuple[str, Any] | None = None
    killed = False

    def announce() -> None:
        if notify is not None:
            notify(job.id)

    if job.cancel_requested:
        stop.set()
    while outcome is None:
        try:
            kind, payload = messages.get(timeout=0.2)
        except queue.Empty:
            kind, payload = "", None
        # A store that does not answer for a moment costs progress reports, not the job.
        if kind == "progress":
            _quietly(job, "progress", store.set_progress, job.id, payload, worker=worker)
            pending["progress"] = payload
        elif kind == "incumbent":
            progress, layout_json = payload
            _quietly(job, "incumbent", store.set_incumbent, job.id, layout_json, worker=worker)
            pending["incumbent"] = {"progress": progress, "layout": json.loads(layout_json)}
        elif kind in ("done", "error"):
            outcome = (kind, payload)
        now = time.monotonic()
        if pending and (now - last_flush >= EVENT_INTERVAL or outcome is not None):
            for event_kind, data in pending.items():
                _quietly(job, "event", store.add_event, job.id, event_kind, data)
            pending.clear()
            last_flush = now
            announce()
        if lease is not None and now - lease.last >= lease.every:
            lease.last = now
            cancel = _quietly(job, "lease", store.heartbeat, job.id, lease.worker,
                              failed=False)
            if cancel is None:  # the reconciler gave the job to another worker
                process.kill()
                process.join(timeout=grace + 1)
                return "lost"
            if cancel:
                stop.set()
        if stopping.is_set() and outcome is None:
            process.kill()
        if outcome is None and not process.is_alive() and messages.empty():
            break
        if now > interrupt_at:
            stop.set()
        if now > kill_at and process.is_alive():
            process.kill()
            killed = True
    process.join(timeout=grace + 1)
    if process.is_alive():
        process.kill()
    if stopping.is_set() and outcome is None:
        return "stopping"
    for attempt in range(FINISH_ATTEMPTS):  # the result is worth a few tries
        try:
            _finish(job, store, outcome, process.exitcode, killed, worker)
            break
        except Exception:
            if attempt == FINISH_ATTEMPTS - 1:
                raise
            log.warning("job %s: the end not recorded yet; trying again", job.id)
            time.sleep(1.0)
    announce()
    return "finished"


def _quietly(job: Job, what: str, write: Callable[..., Any], *args: Any,
             failed: Any = None, **kwargs: Any) -> Any:
    """`write(*args, **kwargs)`, or `failed` (logged) when the store did not take it."""
    try:
        return write(*args, **kwargs)
    except Exception as err:
        log.warning("job %s: %s not recorded (%s)", job.id, what, err)
        return failed


def _finish(
    job: Job, store: JobStore, outcome: tuple[str, Any] | None, exitcode: int | None,
    killed: bool, worker: str | None,
) -> None:
    cancel = bool((current := store.get(job.id)) and current.cancel_requested)
    if outcome is None:
        reason = ("the solve exceeded its time limit and was killed" if killed else
                  f"the solver process died (exit code {exitcode})")
        store.finish(job.id, JobStatus.FAILED, worker=worker,
                     error={"code": "worker_died", "message": reason})
        return
    kind, payload = outcome
    if kind == "error":
        store.finish(job.id, JobStatus.FAILED, worker=worker,
                     error={"code": "solver_error", "message": str(payload)})
        return
    report = json.loads(payload)["report"]
    termination = report["termination"]
    if cancel:
        status = JobStatus.CANCELED
    elif termination in ("infeasible", "no_solution"):
        status = JobStatus.FAILED
    else:
        status = JobStatus.SUCCEEDED
    error = job_failure(termination, report) if status is JobStatus.FAILED else None
    store.finish(job.id, status, termination=termination, result=payload, error=error,
                 worker=worker)


@dataclass
class _Active:
    job: Job
    child: Child


class Runner:
    """The embedded mode: dispatches jobs from the store to child processes of this
    process and records what they report."""

    def __init__(self, store: JobStore, settings: Settings) -> None:
        self.store = store
        self.settings = settings
        self._processes = SolveProcesses(settings.subdomain_processes_per_solve)
        self._active: dict[str, _Active] = {}
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None

    # Life cycle.

    def start(self) -> None:
        requeued, failed = self.store.recover(self.settings.retry_limit)
        if requeued or failed:
            log.info("recovered jobs: %d requeued, %d failed", requeued, failed)
        self._thread = threading.Thread(target=self._dispatch, name="dispatcher", daemon=True)
        self._thread.start()

    @property
    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def stop(self) -> None:
        """Hand the running jobs back to the queue and stop their processes: after a
        restart they run again (a graceful stop does not count as an attempt)."""
        self._stopping.set()
        self._wake.set()
        with self._lock:
            active = list(self._active.values())
        for a in active:
            a.child.stop.set()
            a.child.process.kill()
            self.store.hand_back(a.job.id)
        for a in active:
            a.child.process.join(timeout=5)
        self._processes.close()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def notify(self) -> None:
        """A job was queued: look now rather than at the next poll."""
        self._wake.set()

    def cancel(self, job_id: str) -> None:
        """Ask a job to stop; a running solve returns its incumbent, which is kept."""
        self.store.request_cancel(job_id)
        with self._lock:
            active = self._active.get(job_id)
        if active is not None:
            active.child.stop.set()

    @property
    def running(self) -> int:
        with self._lock:
            return len(self._active)

    # Dispatching.

    def _dispatch(self) -> None:
        last_purge = 0.0
        while not self._stopping.is_set():
            try:
                while self.running < self.settings.workers and not self._stopping.is_set():
                    job = self.store.claim_next()
                    if job is None:
                        break
                    self._launch(job)
                self._processes.refill(self.settings.workers - self.running)
                if time.monotonic() - last_purge > 60:
                    last_purge = time.monotonic()
                    self.store.purge(time.time() - self.settings.retention_hours * 3600)
            except Exception:  # keep dispatching whatever one job did
                log.exception("dispatcher error")
            self._wake.wait(POLL_SECONDS)
            self._wake.clear()

    def _launch(self, job: Job) -> None:
        child = self._processes.take()
        child.start(job.problem)
        with self._lock:
            self._active[job.id] = _Active(job, child)
        threading.Thread(target=self._monitor, args=(job, child),
                         name=f"monitor-{job.id}", daemon=True).start()

    def _monitor(self, job: Job, child: Child) -> None:
        try:
            watch(job, child, self.store, self.settings, stopping=self._stopping)
        except Exception:
            log.exception("monitor of job %s failed", job.id)
            self.store.finish(job.id, JobStatus.FAILED,
                              error={"code": "internal", "message": "the service lost this job"})
        finally:
            with self._lock:
                self._active.pop(job.id, None)
            self._wake.set()


def job_failure(termination: str, report: dict[str, Any]) -> dict[str, Any]:
    """The error of a job that ended without a layout, from its report: the reason, the
    cheap impossibilities and, for an infeasible problem, the conflict found."""
    why = report.get("infeasibility") or {}
    return {"code": termination, "message": why.get("reason", termination),
            "findings": why.get("findings", []), "conflict": why.get("conflict")}
