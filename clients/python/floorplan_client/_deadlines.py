"""Deadlines on the monotonic clock, for the calls that wait (`Job.wait`, event streams)."""

from __future__ import annotations

import time


def deadline_after(timeout: float | None) -> float | None:
    """The monotonic time `timeout` seconds from now; None for no deadline."""
    if timeout is not None and timeout < 0:
        raise ValueError("timeout must be 0 or more (None: no limit)")
    return None if timeout is None else time.monotonic() + timeout


def remaining(deadline: float | None) -> float | None:
    """Seconds left until `deadline` (negative once past); None for no deadline."""
    return None if deadline is None else deadline - time.monotonic()


def expired(deadline: float | None) -> bool:
    """True once `deadline` has passed."""
    left = remaining(deadline)
    return left is not None and left <= 0
