"""The time policy of a solve, in one place (docs/method.md, "When a solve ends").

The limit (paper Sec. 5.4: 5 s up to 20 rooms, growing in proportion on large floors) is
a ceiling: a solve ends sooner when more time is unlikely to buy anything (the stall
rule below). Within it, a floor's stages get named shares (`FloorBudget`, one table):

| stage             | until         | share                                              |
|-------------------|---------------|----------------------------------------------------|
| level 1           | level_one_end | 90 % of the search time                            |
| refinement levels | search_end    | what level 1 leaves of the search time             |
| reshaping         | end           | 1/4 of the time to the report, <= 1 s + 0.1 s/room |
| SCIP's check      | judge_end     | 10 % of the limit, <= 0.3 s + 0.03 s/room, taken   |
|                   |               | from the reshaping's share                         |
| last gaps, report | the limit     | 10 ms a room, at most 10 % of the limit            |

A stage that stalls ends early and leaves its time to the next. Under the default limit
a search with no first layout may go on longer (`late_allowance`: 10 s up to 8 rooms,
24.4 s at 14), the later stages then keeping their shares (`FloorBudget.shifted`).
"""

from __future__ import annotations

from dataclasses import dataclass

#: Seconds per job up to `BASE_ROOMS` rooms, then in proportion (Sec. 5.4: 5 s for up to
#: 20 rooms). For 9 to 14 rooms this was 1.2 s more a room (12.2 s at 14); what that
#: bought was above all a first layout for the hardest briefs, which the late allowance
#: below keeps. With 5 s, 36 planted briefs (medians of three seeds) kept 36 of 36 valid
#: and 32 of 34 within 2x their plan's area error in a quarter less time (bench/NOTES.md,
#: "The paper's 5 s again, with a long late allowance").
BASE_TIME = 5.0
BASE_ROOMS = 20
#: A solve under the default limit that has no layout yet when its search's share ends
#: goes on looking for its first one until `LATE_FIRST_FACTOR` x `late_limit(rooms)`,
#: and the stages after it keep their shares from then on (`FloorBudget.shifted`). A busy
#: machine then slows the answer instead of losing it: with another process on one of
#: two cores, house-13 through `floorplan solve` ended `no_solution` at 2 of 6 seeds at
#: its 12.2 s default (bench/NOTES.md, "A busy machine: a late first layout instead of
#: none"), and briefs of 9 to 14 rooms extracted from real plans, which often need L
#: rooms, may take 10-15 s to their first layout on this 2-core machine. A limit the user
#: gives is never passed.
LATE_FIRST_FACTOR = 2.0
#: `late_limit`: 1.2 s more a room from `MID_ROOMS` to `MID_TOP` rooms (bench/NOTES.md,
#: "A notch wall held from one side only; time for a dozen rooms, again": 86 planted
#: briefs, 77-78 valid with 5 s, 80 with this time, before the late allowance existed).
MID_ROOMS = 8
PER_MID_ROOM = 1.2
MID_TOP = 14


def default_time_limit(rooms: int) -> float:
    """5 s up to 20 rooms, then 0.25 s a room (Sec. 5.4)."""
    return max(BASE_TIME, BASE_TIME * rooms / BASE_ROOMS)


def late_limit(rooms: int) -> float:
    """The default limit, or 5 s and 1.2 s a room from 8 to 14 rooms (12.2 s at 14) where
    that is more: the time a first layout of a brief of a dozen rooms may need."""
    mid = BASE_TIME + PER_MID_ROOM * max(0, min(rooms, MID_TOP) - MID_ROOMS)
    return max(mid, default_time_limit(rooms))


def first_pass_end(started: float, rooms: int) -> float:
    """Under the default limit, when the first pass of the search for a first layout
    ends (the late allowance's second pass may follow): where SCIP's check would end
    under `late_limit`. A hard brief's first layout comes after 5-10 s; a first pass cut
    at the 5 s limit's end and started again lost planted-12-1029's in 3 runs of 3."""
    return FloorBudget.of(started, late_limit(rooms), rooms).judge_end


def late_allowance(rooms: int) -> float:
    """Seconds a one-floor solve under the default limit may run when its first layout
    comes late: `LATE_FIRST_FACTOR` x `late_limit`."""
    return LATE_FIRST_FACTOR * late_limit(rooms)


# When a solve ends (`options.stop: "stalled"`, docs/method.md, "When a solve ends"): the
# time limit is a ceiling. Once a layout covers the floor, the solve ends when its best
# Eq. 12 has not improved by `STALL_GAIN` of its value within the last `STALL_SHARE` of
# the time spent, and never sooner than `STALL_SECONDS` after the last gain: a search that
# improved at 2 s gets until 2.9 s to improve again (2 / (1 - 0.3) ≈ 2.9), one that
# improved at 8 s until 11.4 s.
#: Relative lowering of Eq. 12 that counts as progress (smaller is noise to a user).
STALL_GAIN = 0.005
#: Absolute lowering that always counts (m² of Eq. 12), for objectives near zero.
STALL_GAIN_ABS = 1e-3
#: Share of the time spent so far that the search may go without progress ...
STALL_SHARE = 0.3
#: ... and at least this many seconds.
STALL_SECONDS = 0.25


def stall_window(elapsed: float) -> float:
    """Seconds without progress after which a solve that has spent `elapsed` seconds
    ends."""
    return max(STALL_SECONDS, STALL_SHARE * elapsed)


def significant_gain(before: float, after: float) -> bool:
    """Whether lowering Eq. 12 from `before` to `after` counts as progress."""
    return before - after > max(STALL_GAIN * abs(before), STALL_GAIN_ABS)


#: SCIP's check of the answer (solver/pipeline/judge.py) keeps this share of the limit
#: at the end of a solve ...
JUDGE_SHARE = 0.1
#: ... up to this many seconds and this many more per room.
JUDGE_SECONDS = 0.3
JUDGE_SECONDS_PER_ROOM = 0.03


def judge_seconds(limit: float, rooms: int) -> float:
    """Seconds kept at the end of a solve of `rooms` rooms within `limit` for SCIP to
    take the answer as a start of the whole floor's MIQP and polish it."""
    return min(JUDGE_SHARE * limit, JUDGE_SECONDS + JUDGE_SECONDS_PER_ROOM * rooms)


#: Share of the search time level 1 may use (the refinement levels have the rest).
LEVEL_ONE_SHARE = 0.9
#: Share of the time before it kept for reshaping the rooms at the end, up to
#: `RESHAPE_SECONDS` and `RESHAPE_SECONDS_PER_ROOM` more per room; the reshaping also
#: takes what the refinement leaves. A quarter rather than 15 %: 56 planted briefs,
#: three runs each way, 42-43 -> 43-45 within 2x the plan's area error (bench/NOTES.md).
RESHAPE_SHARE = 0.25
RESHAPE_SECONDS = 1.0
RESHAPE_SECONDS_PER_ROOM = 0.1
#: Share of the reshaping's time it keeps when the refinement ends short of the coverage
#: goal: the rest goes to another round of refinement levels first.
SHORT_RESHAPE_SHARE = 0.25
#: Time kept per room for closing the last gaps and checking the layout, at most
#: `FINISH_SHARE` of the limit.
FINISH_SECONDS_PER_ROOM = 0.01
FINISH_SHARE = 0.1


@dataclass(frozen=True)
class FloorBudget:
    """When each stage of one floor's solve must end (`time.monotonic()` seconds)."""

    started: float
    limit: float
    level_one_end: float
    search_end: float
    #: The refinement's second round, when the first ends short of the coverage goal,
    #: may run until here, taken from the reshaping.
    short_end: float
    end: float
    judge_end: float
    #: A search that has no first layout yet may go on until here (`LATE_FIRST_FACTOR`;
    #: `judge_end` when the user gave the limit).
    late_by: float

    @classmethod
    def of(cls, started: float, limit: float, rooms: int, *, late: bool = False
           ) -> FloorBudget:
        """The shares of a floor of `rooms` rooms solved from `started` within `limit`;
        with `late` (the limit is the default), the first layout's late allowance."""
        finish = min(FINISH_SHARE * limit, FINISH_SECONDS_PER_ROOM * rooms)
        judge_end = started + limit - finish
        reshaping = min(RESHAPE_SHARE * (judge_end - started),
                        RESHAPE_SECONDS + RESHAPE_SECONDS_PER_ROOM * rooms)
        search_end = judge_end - reshaping
        # SCIP's check comes out of the reshaping's share, never the search's: a first
        # layout matters more than its polish.
        end = max(judge_end - judge_seconds(limit, rooms), search_end)
        late_by = judge_end + max(0.0, late_allowance(rooms) - limit) if late else judge_end
        return cls(started, limit, started + (search_end - started) * LEVEL_ONE_SHARE,
                   search_end, judge_end - SHORT_RESHAPE_SHARE * reshaping, end, judge_end,
                   late_by)

    def shifted(self, now: float) -> FloorBudget:
        """After a first layout found at `now`, past level 1's share: every later stage
        ends as much later as the layout came, so that each keeps its share, but never
        past `late_by`."""
        by = max(0.0, min(now - self.level_one_end, self.late_by - self.judge_end))
        return FloorBudget(self.started, self.limit + by, self.level_one_end + by,
                           self.search_end + by, self.short_end + by, self.end + by,
                           self.judge_end + by, self.late_by)

    def hard(self, now: float, rooms: int) -> FloorBudget:
        """Under the default limit, after a first layout found at `now`, past level 1's
        share: a hard brief, whose later stages get the shares of `late_limit` (the
        longer time a dozen rooms may need), shifted to start now where even those have
        passed, never past `late_by`."""
        longer = FloorBudget.of(self.started, max(self.limit, late_limit(rooms)), rooms,
                                late=True)
        return longer.shifted(now) if now > longer.level_one_end else longer

    def table(self) -> str:
        """The shares as seconds from the start, one line each (for logs and docs)."""
        rows = [("level 1", self.level_one_end), ("refinement", self.search_end),
                ("reshaping", self.end), ("SCIP's check", self.judge_end),
                ("last gaps and report", self.started + self.limit)]
        return "\n".join(f"{name:22s} until {at - self.started:6.2f} s" for name, at in rows)
