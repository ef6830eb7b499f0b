"""The sub-domains of one hierarchy level, solved at the same time.

The sub-domains of a level (Sec. 5.3) are disjoint sets of rooms, each an MIQP over its
own rooms and the gaps they touch, with everything else fixed. Given a
`SubdomainExecutor` (any `concurrent.futures.Executor`, a local process pool or one
whose futures are remote tasks, and how many tasks it runs at once), `solve` plans
every sub-domain of a level from the level's layout, solves them at once with
`solve_subdomain`, and applies the results in order. Two sub-domains that
touch one gap may both grow into it: a result overlapping rooms placed meanwhile is
dropped (its rooms keep their rectangles), so the layout stays valid.

The same executor runs a second level-1 search alongside the solve's own, under
another seed (`LevelOneTask`, `solver.pipeline.second_search.level_one_alone`); the
better of the two layouts goes on to the hierarchy. A remote executor that runs only
sub-domains refuses it, and the solve goes on alone.

What crosses to the executor is plain data (a `LevelSpec`, boxes, numbers), so tasks
pickle; the solver knows nothing of who runs them. `solver.pipeline.pool`
starts and ends the local kind, for the command line and the service's solve processes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Mapping
from concurrent.futures import Executor
from dataclasses import dataclass

from floorplan.models import ExtraRectangles, Problem
from floorplan.solver.geometry import Box
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.scip_run import add_start, run_level
from floorplan.solver.miqp.spec import LevelSpec
from floorplan.solver.pipeline.hierarchy import Piece

#: Overlap (m²) below which two rectangles count as touching, not overlapping.
OVERLAP_TOLERANCE = 1e-6
#: A sub-domain left with less time than this is not started.
MIN_SECONDS = 0.05
#: Seconds past a level's deadline its sub-domains are still waited for; a later result
#: is dropped, so a slow task cannot push the solve past its time limit.
LATE_SECONDS = 0.5


@dataclass(frozen=True)
class SubdomainExecutor:
    """Where sub-domains are solved: `executor` runs `slots` tasks at once."""

    executor: Executor
    slots: int

    def budget(self, level_seconds: float, tasks: int) -> float:
        """Seconds per task when `tasks` share `level_seconds` in waves of `slots`."""
        return level_seconds / math.ceil(tasks / max(1, self.slots))


@dataclass(frozen=True)
class SubdomainTask:
    """One sub-domain's MIQP, its feasible start, the seconds it may take, and the wall
    clock time (epoch) by which it must end whenever it starts (a task queued behind
    others gets what is left)."""

    spec: LevelSpec
    start: dict[str, Box]
    budget: float
    deadline: float
    seed: int


@dataclass(frozen=True)
class LevelOneTask:
    """A second level-1 search (`solver.pipeline.second_search.level_one_alone`): the
    problem, under another seed, and the wall clock time (epoch) by which it must end."""

    problem: Problem
    deadline: float


@dataclass(frozen=True)
class LevelOneOutcome:
    """What a level-1 search ends with: its pieces (None: no layout), the extra
    rectangles it gave rooms, its size window, whether soft constraints were priced,
    and the relaxations it tried."""

    pieces: list[Piece] | None
    wings: dict[str, int]
    extra: list[ExtraRectangles]
    window: float | None
    soft: bool
    relaxations: list[str]
    #: Which search it was, as the report's relaxations name it.
    found_by: str = "a second level-1 search, under another seed"


@dataclass(frozen=True)
class SubdomainOutcome:
    status: str  # a LevelStatus value, or why the start was refused
    rects: dict[str, Box] | None
    objective: float | None
    seconds: float  # wall time in the executor, for the speed-up figures


def solve_subdomain(task: SubdomainTask) -> SubdomainOutcome:
    """Build, start and solve one sub-domain (in whatever process the executor uses).
    It has no stop flag: it ends within its budget."""
    started = time.monotonic()

    def left() -> float:  # building the model counts too
        return min(task.budget - (time.monotonic() - started), task.deadline - time.time())

    if left() < MIN_SECONDS:
        return SubdomainOutcome("not started: the level's time ran out", None, None, 0.0)
    lm = build_level(task.spec)
    start = add_start(lm, task.start)
    if start.values is None:
        return SubdomainOutcome(f"start not feasible: {start.status}", None, None,
                                time.monotonic() - started)
    result = run_level(lm, time_limit=max(left(), MIN_SECONDS), seed=task.seed)
    return SubdomainOutcome(str(result.status), result.rects, result.objective,
                            time.monotonic() - started)


def overlaps_others(rooms: Mapping[str, Iterable[Box]], own: set[str],
                    boxes: Iterable[Box]) -> bool:
    """Whether any of `boxes` overlaps a rectangle of a room not in `own`."""
    boxes = list(boxes)
    for room_id, placed in rooms.items():
        if room_id in own:
            continue
        for a in placed:
            for b in boxes:
                dx = min(a.x1, b.x1) - max(a.x0, b.x0)
                dy = min(a.y1, b.y1) - max(a.y0, b.y0)
                if dx > 0 and dy > 0 and dx * dy > OVERLAP_TOLERANCE:
                    return True
    return False
