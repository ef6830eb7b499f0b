"""Time limits (paper Sec. 5.4, which gives 5 s up to 20 rooms): 5 s for small floors,
more for a flat's dozen rooms, growing in proportion beyond."""

from __future__ import annotations

#: Seconds per job up to `BASE_ROOMS` rooms (Sec. 5.4) ...
BASE_TIME = 5.0
BASE_ROOMS = 20
#: ... from `MID_ROOMS` rooms on, `PER_MID_ROOM` s more for each room up to
#: `BASE_ROOMS`: briefs of 9 to 14 rooms extracted from real plans often need L rooms
#: and found no valid layout in 5 s (bench/NOTES.md, "Tilings over subtrees, halves
#: swapped, and time for a dozen rooms").
MID_ROOMS = 8
PER_MID_ROOM = 0.6


def default_time_limit(rooms: int) -> float:
    """5 s up to 8 rooms, 0.6 s more a room up to 20 (12.2 s), then in proportion to
    the room count once that gives more (49 rooms on)."""
    mid = BASE_TIME + PER_MID_ROOM * max(0, min(rooms, BASE_ROOMS) - MID_ROOMS)
    return max(mid, BASE_TIME * rooms / BASE_ROOMS)
