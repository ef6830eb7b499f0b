"""Per-key fairness (docs/security.md, "The limits"): open event streams per key and in
all, explaining validations per key in their own bounded pool of processes, and the 429
each refusal answers, naming its limit. Counted in this API process (jobs per key are
counted in the store, by the route)."""

from __future__ import annotations

import asyncio
import logging
import multiprocessing
import threading
import weakref
from collections import Counter
from collections.abc import AsyncIterator, Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

from floorplan.service.api.errors import ApiError
from floorplan.service.settings import Settings
from floorplan.service.store import Quota, QuotaExceeded

log = logging.getLogger("floorplan.api")
T = TypeVar("T")

#: Retry-After (seconds) of a refusal by a per-key limit.
RETRY_AFTER = 5
#: Retry-After (seconds) of an explanation whose process was lost.
EXPLAIN_RETRY_AFTER = 2


def too_many(what: str, count: int, limit: int, variable: str, kind: str) -> ApiError:
    """The 429 of a limit reached: its problem document names the limit and its setting."""
    return ApiError(429, f"{what}: {count} of at most {limit} ({variable}); try again when "
                    "one has ended", kind=kind, title="Too Many Requests",
                    headers={"Retry-After": str(RETRY_AFTER)})


def quota(settings: Settings) -> Quota:
    """The job limits the store admits new jobs within, counted in the inserting
    transaction."""
    return Quota(per_key=settings.max_jobs_per_key, queue=settings.queue_limit)


def refusal(err: QuotaExceeded, adding: int) -> ApiError:
    """The 429 of jobs the store would not admit (`adding` of them)."""
    if err.what == "key":
        return too_many(f"this key's queued and running jobs with the {adding} new",
                        err.count, err.limit, "FLOORPLAN_MAX_JOBS_PER_KEY", "too-many-jobs")
    return ApiError(429, f"the queue cannot take {adding} more job(s): {err.count} queued "
                    f"of at most {err.limit} (FLOORPLAN_QUEUE_LIMIT); try fewer or later",
                    kind="queue-full", headers={"Retry-After": str(RETRY_AFTER)})


class Limits:
    """What one API process counts per key. The event loop is the only caller, so the
    counts need no lock."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.streams: Counter[str] = Counter()
        self.explains: Counter[str] = Counter()
        #: SCIP's explain checks, in processes of their own: SCIP holds the GIL while it
        #: solves, so in a thread it would hold up the event loop, and a burst of them
        #: waits here rather than taking threads from parsing or the event streams.
        self.explain_pool = self._new_pool()
        self._replacing = threading.Lock()

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(self.settings.explain_processes,
                                   mp_context=multiprocessing.get_context("spawn"))

    def close(self) -> None:
        self.explain_pool.shutdown(wait=False, cancel_futures=True)

    async def run_explain(self, work: Callable[[], T]) -> T:
        """`work` in the explain pool. A pool whose process died (killed, as the OOM
        killer would) is broken for good: it is replaced, and the calls it held answer
        503 explain-unavailable, to be tried again, rather than every later call a 500."""
        pool = self.explain_pool
        try:
            return await asyncio.get_running_loop().run_in_executor(pool, work)
        except BrokenProcessPool as err:
            self._replace(pool)
            raise ApiError(503, "the process explaining this validation was lost; try "
                           "again", kind="explain-unavailable",
                           headers={"Retry-After": str(EXPLAIN_RETRY_AFTER)}) from err

    def explain_ready(self) -> bool:
        """Whether the explain pool can take work; a broken one is replaced here too,
        so that a node that takes no explanation for a while is not left unready."""
        pool = self.explain_pool
        # The executor marks itself broken as soon as one of its processes dies.
        if not getattr(pool, "_broken", False):
            return True
        self._replace(pool)
        return False

    def _replace(self, pool: ProcessPoolExecutor) -> None:
        # /readyz runs in a worker thread, explanations on the event loop: one replaces.
        with self._replacing:
            if self.explain_pool is not pool:  # replaced by another call already
                return
            log.warning("an explain process was lost; the explain pool is replaced")
            self.explain_pool = self._new_pool()
        pool.shutdown(wait=False, cancel_futures=True)

    def stream(self, owner: str, events: AsyncIterator[str]) -> AsyncIterator[str]:
        """`events` counted as one of `owner`'s open streams until it ends, is closed
        or is dropped unread (a client gone before the first byte); 429 when the key or
        the process has as many open as the settings allow."""
        s = self.settings
        total = sum(self.streams.values())
        if self.streams[owner] >= s.max_streams_per_key:
            raise too_many("this key's open event streams", self.streams[owner],
                           s.max_streams_per_key, "FLOORPLAN_MAX_STREAMS_PER_KEY",
                           "too-many-streams")
        if total >= s.max_streams:
            raise too_many("open event streams on this node", total, s.max_streams,
                           "FLOORPLAN_MAX_STREAMS", "too-many-streams")
        self.streams[owner] += 1
        release = _once(lambda: self._leave(self.streams, owner))

        async def counted() -> AsyncIterator[str]:
            try:
                async for chunk in events:
                    yield chunk
            finally:
                release()

        body = counted()
        weakref.finalize(body, release)  # never iterated: released when dropped
        return body

    def explain(self, owner: str) -> Callable[[], None]:
        """Take one of `owner`'s explain slots (429 when none is left); the function
        returned gives it back."""
        limit = self.settings.max_explains_per_key
        if self.explains[owner] >= limit:
            raise too_many("this key's explaining validations", self.explains[owner], limit,
                           "FLOORPLAN_MAX_EXPLAINS_PER_KEY", "too-many-explains")
        self.explains[owner] += 1
        return _once(lambda: self._leave(self.explains, owner))

    @staticmethod
    def _leave(counts: Counter[str], owner: str) -> None:
        counts[owner] -= 1
        if counts[owner] <= 0:
            del counts[owner]


def _once(action: Callable[[], None]) -> Callable[[], None]:
    done = False

    def run() -> None:
        nonlocal done
        if not done:
            done = True
            action()

    return run
