"""Following a job by polling, I/O-free like the rest of the core: the pauses between
polls (`Pauses`), and what a follower has seen, so that polled job states become the
events a stream would have sent and a switch from the stream repeats nothing
(`Tracker`)."""

from __future__ import annotations

import random

from floorplan_client import _constants as C
from floorplan_client.types import (
    Event,
    IncumbentEvent,
    JobInfo,
    JobStatus,
    Layout,
    Progress,
    ProgressEvent,
    StatusEvent,
)


class Pauses:
    """Pauses between polls: exponential from `POLL_INITIAL` up to `POLL_MAX`, with
    jitter, back to the start when something changed."""

    def __init__(self, rng: random.Random) -> None:
        self._random = rng
        self._next = C.POLL_INITIAL

    def next(self) -> float:
        """The next pause in seconds."""
        pause = self._next * self._random.uniform(1 - C.POLL_JITTER, 1)
        self._next = min(self._next * C.POLL_FACTOR, C.POLL_MAX)
        return pause

    def reset(self) -> None:
        """Something changed: poll soon again."""
        self._next = C.POLL_INITIAL


class Tracker:
    """What a follower of a job has seen, so that polling yields only what changed and a
    switch from the stream to polling repeats nothing."""

    def __init__(self) -> None:
        self.status: JobStatus | None = None
        self.progress: Progress | None = None
        self.layout: Layout | None = None
        self.wants_layout = False
        self.ended = False

    def seen(self, event: Event) -> None:
        """Note an event from the stream."""
        if isinstance(event, StatusEvent):
            self.status = event.status
            self.ended = event.status.terminal
        elif isinstance(event, ProgressEvent):
            self.progress = event.progress
        else:
            self.layout = event.layout

    def changes(self, info: JobInfo) -> list[Event]:
        """The events that lead from what was seen to `info`: a new status first, or last
        when it ends the job; a new progress in between. Afterwards `wants_layout` says
        whether the incumbent may have changed."""
        events: list[Event] = []
        status = None
        if info.status is not self.status:
            status = StatusEvent(status=info.status, termination=info.termination,
                                 error=info.error)
            self.status = info.status
        if status is not None and not info.status.terminal:
            events.append(status)
        progressed = info.progress is not None and info.progress != self.progress
        if progressed:
            assert info.progress is not None
            events.append(ProgressEvent(progress=info.progress))
            self.progress = info.progress
        self.wants_layout = info.status is JobStatus.RUNNING and (progressed or bool(events))
        if status is not None and info.status.terminal:
            events.append(status)
            self.ended = True
        return events

    def incumbent(self, layout: Layout) -> IncumbentEvent | None:
        """An incumbent event for `layout` unless it was seen already."""
        if layout == self.layout:
            return None
        self.layout = layout
        return IncumbentEvent(progress=self.progress or Progress(), layout=layout)
