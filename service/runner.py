"""Runs queued jobs: each solve in its own spawned process, at most `workers` at once,
first in first out, under a watchdog.

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
from dataclasses import dataclass, field
from multiprocessing.synchronize import Event
from typing import Any

from service.settings import Settings
from service.store import Job, JobStatus, JobStore
from service.worker import standby

log = logging.getLogger("floorplan.runner")

#: Seconds a child may take to start (imports of SCIP, shapely) before its clock runs.
STARTUP_SECONDS = 10.0
#: Progress and incumbent events are written at most this often per job (2 a second).
EVENT_INTERVAL = 0.5
#: How often the runner looks for new work when nobody wakes it (seconds).
POLL_SECONDS = 0.5


@dataclass
class _Standby:
    """A solve process already started and warmed up, waiting for its job."""

    process: Any
    jobs: Any  # the sending end of the pipe its job goes down
    messages: Any
    stop: Event


@dataclass
class _Active:
    job: Job
    process: Any
    stop: Event
    started: float = field(default_factory=time.monotonic)


class Runner:
    """Dispatches jobs from the store to child processes and records what they report."""

    def __init__(self, store: JobStore, settings: Settings) -> None:
        self.store = store
        self.settings = settings
        self._ctx = multiprocessing.get_context("spawn")
        self._active: dict[str, _Active] = {}
        self._standby: list[_Standby] = []
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
            a.stop.set()
            a.process.kill()
            self.store.hand_back(a.job.id)
        for a in active:
            a.process.join(timeout=5)
        for s in self._standby:
            s.process.kill()
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
            active.stop.set()

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
                self._refill()
                if time.monotonic() - last_purge > 60:
                    last_purge = time.monotonic()
                    self.store.purge(time.time() - self.settings.retention_hours * 3600)
            except Exception:  # keep dispatching whatever one job did
                log.exception("dispatcher error")
            self._wake.wait(POLL_SECONDS)
            self._wake.clear()

    def _launch(self, job: Job) -> None:
        ready = self._take_standby()
        ready.jobs.send(job.problem)
        ready.jobs.close()
        active = _Active(job, ready.process, ready.stop)
        with self._lock:
            self._active[job.id] = active
        if job.cancel_requested:
            ready.stop.set()
        threading.Thread(target=self._monitor, args=(active, ready.messages),
                         name=f"monitor-{job.id}", daemon=True).start()

    def _take_standby(self) -> _Standby:
        while self._standby:
            ready = self._standby.pop(0)
            if ready.process.is_alive():
                return ready
        return self._start_standby()

    def _refill(self) -> None:
        """Keep one warmed-up process ready per idle worker slot: a job then starts
        without waiting about a second for imports."""
        while len(self._standby) + self.running < self.settings.workers:
            self._standby.append(self._start_standby())

    def _start_standby(self) -> _Standby:
        receive, send = self._ctx.Pipe(duplex=False)
        messages = self._ctx.Queue()
        stop = self._ctx.Event()
        process = self._ctx.Process(target=standby,
                                    args=(receive, messages, stop, os.getpid()),
                                    name="solve", daemon=True)
        process.start()
        receive.close()
        return _Standby(process, send, messages, stop)

    # Watching one job.

    def _monitor(self, active: _Active, messages: Any) -> None:
        job, process, stop = active.job, active.process, active.stop
        grace = self.settings.grace_seconds
        interrupt_at = active.started + STARTUP_SECONDS + job.time_limit + grace
        kill_at = interrupt_at + grace
        pending: dict[str, Any] = {}
        last_flush = 0.0
        outcome: tuple[str, Any] | None = None
        killed = False
        try:
            while outcome is None:
                try:
                    kind, payload = messages.get(timeout=0.2)
                except queue.Empty:
                    kind, payload = "", None
                if kind == "progress":
                    self.store.set_progress(job.id, payload)
                    pending["progress"] = payload
                elif kind == "incumbent":
                    progress, layout_json = payload
                    self.store.set_incumbent(job.id, layout_json)
                    pending["incumbent"] = {"progress": progress, "layout": json.loads(layout_json)}
                elif kind in ("done", "error"):
                    outcome = (kind, payload)
                now = time.monotonic()
                if pending and (now - last_flush >= EVENT_INTERVAL or outcome is not None):
                    for event_kind, data in pending.items():
                        self.store.add_event(job.id, event_kind, data)
                    pending.clear()
                    last_flush = now
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
            self._finish(job, outcome, process.exitcode, killed)
        except Exception:
            log.exception("monitor of job %s failed", job.id)
            self.store.finish(job.id, JobStatus.FAILED,
                              error={"code": "internal", "message": "the service lost this job"})
        finally:
            with self._lock:
                self._active.pop(job.id, None)
            self._wake.set()

    def _finish(
        self, job: Job, outcome: tuple[str, Any] | None, exitcode: int | None, killed: bool
    ) -> None:
        if self._stopping.is_set() and outcome is None:
            return  # handed back by stop()
        cancel = bool((current := self.store.get(job.id)) and current.cancel_requested)
        if outcome is None:
            reason = ("the solve exceeded its time limit and was killed" if killed else
                      f"the solver process died (exit code {exitcode})")
            self.store.finish(job.id, JobStatus.FAILED,
                              error={"code": "worker_died", "message": reason})
            return
        kind, payload = outcome
        if kind == "error":
            self.store.finish(job.id, JobStatus.FAILED,
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
        self.store.finish(job.id, status, termination=termination, result=payload, error=error)


def job_failure(termination: str, report: dict[str, Any]) -> dict[str, Any]:
    """The error of a job that ended without a layout, from its report: the reason, the
    cheap impossibilities and, for an infeasible problem, the conflict found."""
    why = report.get("infeasibility") or {}
    return {"code": termination, "message": why.get("reason", termination),
            "findings": why.get("findings", []), "conflict": why.get("conflict")}
