"""Process pools of the API process for work that holds the GIL too long to share the
event loop's process (SCIP's explain checks, the exports of large layouts): a bounded
number at once, the rest waiting their turn; a pool whose process died (killed, as
the OOM killer would) replaced rather than broken for good."""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

from floorplan.service.api.errors import ApiError

log = logging.getLogger("floorplan.api")
T = TypeVar("T")

#: Retry-After (seconds) of work whose process was lost.
LOST_RETRY_AFTER = 2
#: Seconds a killed pool process is waited for when the API stops.
PROCESS_EXIT_WAIT = 5.0
#: How often a pool process looks whether the API that started it is still there.
PARENT_CHECK_SECONDS = 1.0


class WorkPool:
    """`processes` spawned processes doing `what` (for the logs and the 503's detail);
    a 503 of problem type `kind` answers the calls a lost process held."""

    def __init__(self, processes: int, what: str, kind: str) -> None:
        self.processes, self.what, self.kind = processes, what, kind
        self.pool = self._new()
        # /readyz runs in a worker thread, the calls on the event loop: one replaces.
        self._replacing = threading.Lock()

    def _new(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(self.processes,
                                   mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_exit_with, initargs=(os.getpid(),))

    def close(self) -> None:
        """Stop the pool with the API: its processes killed, the work they held with
        them (a stopped server answers nothing). Shut down alone, an idle process may
        be left waiting for work for good once the API has exited."""
        processes = list((getattr(self.pool, "_processes", None) or {}).values())
        self.pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            process.kill()
        for process in processes:
            process.join(PROCESS_EXIT_WAIT)

    async def run(self, work: Callable[[], T]) -> T:
        """`work` (picklable) in one of the pool's processes. A pool whose process died
        is broken for good: it is replaced, and the calls it held answer 503, to be
        tried again, rather than every later call a 500."""
        pool = self.pool
        try:
            return await asyncio.get_running_loop().run_in_executor(pool, work)
        except BrokenProcessPool as err:
            self._replace(pool)
            raise ApiError(503, f"the process {self.what} was lost; try again",
                           kind=self.kind,
                           headers={"Retry-After": str(LOST_RETRY_AFTER)}) from err

    def ready(self) -> bool:
        """Whether the pool can take work; a broken one is replaced here too, so that a
        node that gets no call for a while is not left unready."""
        pool = self.pool
        # The executor marks itself broken as soon as one of its processes dies.
        if not getattr(pool, "_broken", False):
            return True
        self._replace(pool)
        return False

    def _replace(self, pool: ProcessPoolExecutor) -> None:
        with self._replacing:
            if self.pool is not pool:  # replaced by another call already
                return
            log.warning("a process %s was lost; its pool is replaced", self.what)
            self.pool = self._new()
        pool.shutdown(wait=False, cancel_futures=True)


def _exit_with(parent: int) -> None:
    """In each pool process, as it starts: exit once `parent` (the API process) is gone,
    killed without a chance to stop its pools (SIGKILL, the OOM killer); an idle
    process would otherwise wait for work from it for good."""
    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_CHECK_SECONDS)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-api", daemon=True).start()
