"""The warm worker pool of `floorplan batch`: a few processes, each importing the solver
(and SCIP) once and then laying out one task after another.

Each worker runs one task at a time, so the pool always knows which task a worker
holds: a worker that dies (a crash in SCIP, the OOM killer) fails that one task and is
replaced, and a task that outlives its hard limit has its worker killed and replaced;
the other tasks carry on. Workers ignore SIGINT: Ctrl-C is the parent's to handle
(`WarmPool.close` ends them). Standard library only at import time, as
service/cli/solve.py needs.
"""

from __future__ import annotations

import multiprocessing
import signal
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from typing import Any

#: Seconds `close` waits for a worker to end before killing it.
CLOSE_SECONDS = 2.0
#: Seconds `results` waits for a message before it checks limits and stop flags again.
POLL_SECONDS = 0.1

#: What `next` gives for a task iterator that has ended.
_EXHAUSTED = object()

#: A task's function: run in a worker, it takes the task's argument and returns a
#: picklable result. It must be a module-level function (workers are spawned).
TaskFunction = Callable[[Any], Any]


@dataclass(frozen=True)
class Outcome:
    """A finished task: its key and either its result or why it failed."""

    key: Any
    result: Any = None
    error: str | None = None


def _worker(conn: Connection, warm_up: str | None) -> None:
    """A worker's loop: import `warm_up` once, say so, then run (function, argument)
    pairs sent on `conn` until it is closed, answering ("ok", result) or ("error",
    message)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if warm_up:
        __import__(warm_up)
    try:
        conn.send(("ready", None))
        while True:
            function, argument = conn.recv()
            try:
                answer = ("ok", function(argument))
            except Exception as err:  # a failed task is data; the worker carries on
                answer = ("error", f"{type(err).__name__}: {err}")
            conn.send(answer)
    except (EOFError, BrokenPipeError):
        return  # the pool closed its end: the batch is over


@dataclass
class _Slot:
    process: BaseProcess
    conn: Connection
    key: Any = None
    started: float = 0.0
    limit: float = 0.0
    #: The worker has imported what it warms up with and waits for tasks (a task's hard
    #: limit counts from when it is handed over, so not before).
    ready: bool = False


class WarmPool:
    """`processes` spawned workers that import `warm_up` once."""

    def __init__(self, processes: int, *, warm_up: str | None = None) -> None:
        self._context = multiprocessing.get_context("spawn")
        self._warm_up = warm_up
        self._slots = [self._start() for _ in range(processes)]

    def _start(self) -> _Slot:
        parent, child = self._context.Pipe()
        process = self._context.Process(target=_worker, args=(child, self._warm_up),
                                        daemon=True)
        process.start()
        child.close()
        return _Slot(process, parent)

    def _replace(self, slot: _Slot) -> None:
        if slot.process.is_alive():
            slot.process.kill()
        slot.process.join(CLOSE_SECONDS)
        slot.conn.close()
        fresh = self._start()
        slot.process, slot.conn, slot.key, slot.ready = fresh.process, fresh.conn, None, False

    def results(
        self, tasks: Iterator[tuple[Any, TaskFunction, Any, float]],
        should_stop: Callable[[], bool] = lambda: False,
    ) -> Iterator[Outcome]:
        """Run (key, function, argument, hard limit in seconds) tasks, yielding each
        outcome as it comes; `tasks` may yield None for "none yet" (a task that an
        outcome still to come may add). Stops handing out tasks once `should_stop` is true and
        returns without waiting for the tasks still running (`close` ends them)."""
        pending = iter(tasks)
        exhausted = False
        while True:
            if not should_stop() and not exhausted:
                for slot in self._slots:
                    if slot.key is not None or not slot.ready:
                        continue
                    task = next(pending, _EXHAUSTED)
                    if task is _EXHAUSTED:
                        exhausted = True
                        break
                    if task is None:
                        break  # nothing to hand out yet: asked again after the next wait
                    key, function, argument, limit = task
                    slot.key, slot.started, slot.limit = key, time.monotonic(), limit
                    slot.conn.send((function, argument))
            busy = [s for s in self._slots if s.key is not None]
            if should_stop() or (exhausted and not busy):
                return
            starting = [s for s in self._slots if not s.ready]
            by_conn = {s.conn: s for s in busy + starting}
            by_sentinel = {s.process.sentinel: s for s in busy}
            ready = wait([*by_conn, *by_sentinel], timeout=POLL_SECONDS)
            answered: set[int] = set()
            for item in ready:
                slot = by_conn.get(item)  # type: ignore[call-overload]
                if slot is None or id(slot) in answered:
                    continue
                try:
                    status, value = slot.conn.recv()
                except (EOFError, OSError):
                    continue  # it died: its sentinel says so below
                if status == "ready":
                    slot.ready = True
                    continue
                answered.add(id(slot))
                key, slot.key = slot.key, None
                yield (Outcome(key, result=value) if status == "ok"
                       else Outcome(key, error=value))
            now = time.monotonic()
            for slot in busy:
                if id(slot) in answered or slot.key is None:
                    continue
                if not slot.process.is_alive():
                    key, code = slot.key, slot.process.exitcode
                    self._replace(slot)
                    yield Outcome(key, error=f"the worker died (exit code {code})")
                elif now - slot.started > slot.limit:
                    key, limit = slot.key, slot.limit
                    self._replace(slot)
                    yield Outcome(key, error=f"killed after its hard limit of {limit:g} s")

    def close(self) -> None:
        """End every worker: idle ones when their pipe closes, busy ones killed."""
        for slot in self._slots:
            if slot.key is not None and slot.process.is_alive():
                slot.process.kill()
            slot.conn.close()
        for slot in self._slots:
            slot.process.join(CLOSE_SECONDS)
            if slot.process.is_alive():
                slot.process.kill()
                slot.process.join()

    def __enter__(self) -> WarmPool:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()
