"""Per-key fairness (docs/security.md, "The limits"): open event streams per key and in
all, explaining validations per key in their own bounded pool of processes, and the 429
each refusal answers, naming its limit. Counted in this API process (jobs per key are
counted in the store, by the route)."""

from __future__ import annotations

import weakref
from collections import Counter
from collections.abc import AsyncIterator, Callable
from typing import TypeVar

from floorplan.service.api.errors import ApiError
from floorplan.service.api.pools import WorkPool
from floorplan.service.settings import Settings
from floorplan.service.store import Quota, QuotaExceeded

T = TypeVar("T")

#: Retry-After (seconds) of a refusal by a per-key limit.
RETRY_AFTER = 5


def too_many(what: str, count: int, limit: int, variable: str, kind: str) -> ApiError:
    """The 429 of a limit reached: its problem document names the limit and its setting."""
    return ApiError(429, f"{what}: {count} of at most {limit} ({variable}); try again when "
                    "one has ended", kind=kind, title="Too Many Requests",
                    headers={"Retry-After": str(RETRY_AFTER)})


def quota(settings: Settings) -> Quota:
    """The job limits the store admits new jobs within, counted in the inserting
    transaction."""
    return Quota(per_key=settings.max_jobs_per_key, queue=settings.queue_limit,
                 stored_bytes=settings.max_stored_bytes_per_key)


def refusal(err: QuotaExceeded, adding: int) -> ApiError:
    """The 429 of jobs the store would not admit (`adding` of them)."""
    if err.what == "bytes":
        return ApiError(429, f"this key's jobs would keep {err.count} bytes in the store, "
                        f"more than {err.limit} (FLOORPLAN_MAX_STORED_BYTES_PER_KEY); delete "
                        "finished jobs (DELETE /v1/layouts/{id}) to make room",
                        kind="storage-quota", title="Too Many Requests")
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
        self.explain_pool = WorkPool(settings.explain_processes,
                                     "explaining this validation", "explain-unavailable")
        #: The exports (IFC, DXF, SVG, GeoJSON) likewise: an IFC of a large layout takes
        #: seconds of pure Python.
        self.export_pool = WorkPool(settings.export_processes, "exporting this layout",
                                    "export-unavailable")

    def close(self) -> None:
        self.explain_pool.close()
        self.export_pool.close()

    async def run_explain(self, work: Callable[[], T]) -> T:
        return await self.explain_pool.run(work)

    async def run_export(self, work: Callable[[], T]) -> T:
        return await self.export_pool.run(work)

    def pools_ready(self) -> dict[str, str]:
        """The pools that lost a process, each replaced by this very check."""
        return {name: "replaced" for name, pool in (("explain", self.explain_pool),
                                                    ("export", self.export_pool))
                if not pool.ready()}

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
