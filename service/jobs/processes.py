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

import contextlib
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

from floorplan.models.jobs import JobStatus
from floorplan.service.jobs.child import standby
from floorplan.service.records import Job
from floorplan.service.settings import Settings
from floorplan.service.store import JobStore

log = logging.getLogger("floorplan.runner")

#: A batch's layout is moved apart from at most this many of its last finished layouts.
HELD_PLANS = 200
#: Seconds a child may take to start (imports of SCIP, shapely) before its clock runs.
STARTUP_SECONDS = 10.0
#: Progress and incumbent events are written at most this often per job (2 a second).
EVENT_INTERVAL = 0.5
#: How often the runner looks for new work when nobody wakes it (seconds).
POLL_SECONDS = 0.5
#: Longest wait (seconds) of the dispatcher after errors in a row, each doubling it.
BACKOFF_MAX = 30.0
#: Seconds a job's end is tried again while the store refuses it (it is then lost, and
#: run again after a restart).
FINISH_PATIENCE = 600.0
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
        """Hand the process its job's problem. The pipe stays open: a batch's layout asks
        for the batch's finished layouts once it is solved (`_Watch.receive`)."""
        self.jobs.send(problem_json)


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
    grace = settings.grace_seconds
    started = time.monotonic()
    interrupt_at = started + STARTUP_SECONDS + job.time_limit + grace
    watched = _Watch(job, child, store, grace, lease, notify,
                     interrupt_at=interrupt_at, kill_at=interrupt_at + grace)
    process = child.process
    # Read again: a cancel that came after the claim, before the runner knew the job as
    # active, is only in the store (a job cancelled 20 ms after its POST ran on to the end).
    current = store.get(job.id)
    if job.cancel_requested or (current is not None and current.cancel_requested):
        child.stop.set()
    while watched.outcome is None:
        watched.receive()
        now = time.monotonic()
        watched.flush(now)
        if not watched.renew_lease(now):
            return "lost"
        if stopping.is_set() and watched.outcome is None:
            process.kill()
        if watched.outcome is None and not process.is_alive() and child.messages.empty():
            break
        watched.enforce_limits(now)
    if watched.outcome is not None:
        # The answer is in: recorded before the process is reaped, since a process with
        # SCIP, shapely and a pool takes a while to exit on a busy machine.
        watched.record_end()
        watched.end_process()
        return "finished"
    watched.end_process()
    if stopping.is_set():
        return "stopping"
    watched.record_end()
    return "finished"


@dataclass
class _Watch:
    """What `watch` keeps of one job's solve: the reports not yet written as events, how
    the solve ended, and its deadlines (the time limit plus grace, then another grace)."""

    job: Job
    child: Child
    store: JobStore
    grace: float
    lease: Lease | None
    notify: Callable[[str], None] | None
    interrupt_at: float
    kill_at: float
    pending: dict[str, Any] = field(default_factory=dict)
    last_flush: float = 0.0
    outcome: tuple[str, Any] | None = None
    killed: bool = False

    @property
    def worker(self) -> str | None:
        return self.lease.worker if self.lease else None

    def announce(self) -> None:
        if self.notify is not None:
            self.notify(self.job.id)

    def receive(self) -> None:
        """Take the solve's next report, if one comes within a moment."""
        job, store, worker = self.job, self.store, self.worker
        try:
            kind, payload = self.child.messages.get(timeout=0.2)
        except queue.Empty:
            return
        # A store that does not answer for a moment costs progress reports, not the job.
        if kind == "progress":
            _quietly(job, "progress", store.set_progress, job.id, payload, worker=worker)
            self.pending["progress"] = payload
        elif kind == "incumbent":
            progress, layout_json = payload
            _quietly(job, "incumbent", store.set_incumbent, job.id, layout_json, worker=worker)
            self.pending["incumbent"] = {"progress": progress, "layout": json.loads(layout_json)}
        elif kind == "held":
            self._send_held()
        elif kind in ("done", "error"):
            self.outcome = (kind, payload)

    def _send_held(self) -> None:
        """Answer a solved layout's ask for the plans it must differ from: for a batch's
        layout, the batch's last `HELD_PLANS` finished layouts (JSON), as the store has
        them now; none for other jobs or when the store cannot say (the layout then
        stays as solved)."""
        held: list[str] = []
        if self.job.batch_id is not None:
            held = _quietly(self.job, "batch plans", self.store.batch_plans,
                            self.job.batch_id, limit=HELD_PLANS, failed=[])
        with contextlib.suppress(OSError, ValueError):  # the solve is gone already
            self.child.jobs.send(held)

    def flush(self, now: float) -> None:
        """Write the pending reports as events, at most every EVENT_INTERVAL, and at the
        end at once."""
        if self.pending and (now - self.last_flush >= EVENT_INTERVAL
                             or self.outcome is not None):
            for event_kind, data in self.pending.items():
                _quietly(self.job, "event", self.store.add_event, self.job.id, event_kind, data)
            self.pending.clear()
            self.last_flush = now
            self.announce()

    def renew_lease(self, now: float) -> bool:
        """Renew the lease when it is due, learning there whether a cancel was asked
        for. False when the job went to another worker: the solve is then killed."""
        lease = self.lease
        if lease is None or now - lease.last < lease.every:
            return True
        lease.last = now
        cancel = _quietly(self.job, "lease", self.store.heartbeat, self.job.id, lease.worker,
                          failed=False)
        if cancel is None:  # the reconciler gave the job to another worker
            self.child.process.kill()
            self.child.process.join(timeout=self.grace + 1)
            return False
        if cancel:
            self.child.stop.set()
        return True

    def enforce_limits(self, now: float) -> None:
        """Past the time limit and grace, stop the solve; past another grace, kill it."""
        if now > self.interrupt_at:
            self.child.stop.set()
        if now > self.kill_at and self.child.process.is_alive():
            self.child.process.kill()
            self.killed = True

    def end_process(self) -> None:
        process = self.child.process
        process.join(timeout=self.grace + 1)
        if process.is_alive():
            process.kill()
        self.child.jobs.close()

    def record_end(self) -> None:
        """Record how the job ended. The result is worth waiting for: while the store
        refuses the write (a full disk, the database away), try again, each wait twice
        the last (at most BACKOFF_MAX), for up to FINISH_PATIENCE seconds."""
        give_up = time.monotonic() + FINISH_PATIENCE
        delay = 1.0
        while True:
            try:
                _finish(self.job, self.store, self.outcome, self.child.process.exitcode,
                        self.killed, self.worker)
                break
            except Exception as err:
                if time.monotonic() + delay > give_up:
                    raise
                log.warning("job %s: the end not recorded yet (%s); trying again in %.0f s",
                            self.job.id, str(err)[:200], delay)
                time.sleep(delay)
                delay = min(delay * 2, BACKOFF_MAX)
        self.announce()


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
        failures = 0
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
            except Exception as err:  # keep dispatching whatever one job did, backing off
                failures += 1
                delay = min(POLL_SECONDS * 2 ** failures, BACKOFF_MAX)
                if failures == 1:
                    log.exception("dispatcher error; trying again in %.0f s", delay)
                else:
                    log.warning("dispatcher error, %d in a row; trying again in %.0f s: %s",
                                failures, delay, str(err)[:300])
                # Submissions do not wake it meanwhile: the store is what failed.
                self._stopping.wait(delay)
                continue
            if failures:
                log.info("dispatcher working again after %d errors", failures)
                failures = 0
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
            try:
                self.store.finish(job.id, JobStatus.FAILED, error={
                    "code": "internal", "message": "the service lost this job"})
            except Exception as err:  # the store still refuses: a restart runs it again
                log.error("job %s: not recorded as failed either (%s)", job.id, str(err)[:200])
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
