"""Time limits (paper Sec. 5.4): 5 s up to 20 rooms, growing in proportion beyond."""

from __future__ import annotations

#: Seconds per job up to `BASE_ROOMS` rooms (Sec. 5.4) ...
BASE_TIME = 5.0
BASE_ROOMS = 20


def default_time_limit(rooms: int) -> float:
    """5 s up to 20 rooms, then in proportion to the room count."""
    return BASE_TIME * max(1.0, rooms / BASE_ROOMS)
