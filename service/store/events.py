"""The events of a job: appended with a sequence number (the SSE event id), read back
after one."""

from __future__ import annotations

import json
import time
from typing import Any

from sqlalchemy import func, insert, select
from sqlalchemy.exc import IntegrityError

from floorplan.service.records import Event
from floorplan.service.store.base import StoreBase
from floorplan.service.tables import events

#: Attempts at appending an event when another writer took its sequence number.
EVENT_RETRIES = 5


class EventLog(StoreBase):
    """Each job's events, in order."""

    def add_event(self, job_id: str, kind: str, data: dict[str, Any] | str) -> int:
        """Append an event; its sequence number is the SSE event id."""
        payload = data if isinstance(data, str) else json.dumps(data)
        for attempt in range(EVENT_RETRIES):
            try:
                with self._tx() as conn:
                    last = conn.execute(select(func.max(events.c.seq))
                                        .where(events.c.job_id == job_id)).scalar()
                    seq = (last or 0) + 1
                    conn.execute(insert(events).values(job_id=job_id, seq=seq, kind=kind,
                                                       data=payload, created_at=time.time()))
                return seq
            except IntegrityError:
                # Two writers took the same number (the runner and a cancel): take the next.
                if attempt == EVENT_RETRIES - 1:
                    raise
        raise AssertionError("unreachable")

    def events_after(self, job_id: str, seq: int) -> list[Event]:
        with self._tx() as conn:
            rows = conn.execute(select(events).where(events.c.job_id == job_id,
                                                     events.c.seq > seq)
                                .order_by(events.c.seq)).all()
        return [Event(r.job_id, r.seq, r.kind, r.data) for r in rows]

    def last_event(self, job_id: str) -> int:
        """The sequence number of `job_id`'s newest event (0: none yet)."""
        with self._tx() as conn:
            last = conn.execute(select(func.max(events.c.seq))
                                .where(events.c.job_id == job_id)).scalar()
        return int(last or 0)
