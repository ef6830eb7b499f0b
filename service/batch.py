"""Batches (docs/cli.md, "floorplan batch"): one brief laid out under many seeds. What
the `floorplan batch` command and the service's batches share: the task of one layout
(`LayoutTask`, run by `lay_out` in whatever process), the row a finished layout leaves
in the summary (`LayoutRow`), and the summary itself (`BatchSummary`: counts, rate,
distinct plans).

Every layout of a batch is solved with ``options.diverse`` (the seed draws the sizes
aimed at and the arrangement leaned to: solver/heuristics/variety.py) and
``options.seed`` = the batch's seed + its index; with `vary_program` the seed also draws
the programme from a templated brief (`models.programme`). A layout that is not good is
laid out again under another draw (`REDRAWS`)."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, Field

from floorplan.models import Layout, Problem, Termination
from floorplan.models.formats import FormatName
from floorplan.models.options import REDRAW_SEED_STEP

if TYPE_CHECKING:
    from floorplan.solver.distinct import DistinctPlans

#: A batch's layouts get this per-layout time limit by default, seconds per room (and at
#: least `BATCH_MIN_SECONDS`): a batch is many plans, each good rather than the best.
#: Measured in bench/README.md, "Batches".
BATCH_SECONDS_PER_ROOM = 0.4
BATCH_MIN_SECONDS = 1.0
#: A layout still running this long after its time limit (times `HARD_LIMIT_FACTOR`,
#: plus `HARD_LIMIT_GRACE` s) has its process killed and fails.
HARD_LIMIT_FACTOR = 2.0
HARD_LIMIT_GRACE = 10.0
#: A layout counts as good when valid and covering at least this share of the floor.
GOOD_COVERAGE = 0.99
#: With a tolerance T, once a brief has this many good layouts, its next solves stop at
#: the first good incumbent whose Eq. 12 is within T of the best so far (relative).
REFERENCE_LAYOUTS = 4
#: By default a layout stops at its first good incumbent, whatever its Eq. 12: each
#: seed aims at its own drawn sizes (options.diverse), so the brief's Eq. 12 of a plan
#: says how far the seed's draw is from the brief's targets, not how well it was
#: solved, and solving on brings the plans back toward the brief's one optimum
#: (measured: bench/README.md, "Batches").
DEFAULT_TOLERANCE = math.inf
#: A layout that is not good (valid, covering `GOOD_COVERAGE`) is laid out again under
#: another draw of sizes, at most this many times; the better of the tries is kept.
REDRAWS = 2
#: With `floorplan batch --distinct`, a good layout whose plan the batch already holds
#: is laid out again under another draw (`LayoutTask.draw`), this many times at most;
#: the first new plan is kept, else the first layout. A draw's seed is the layout's
#: plus `DRAW_SEED_STEP` times the draw.
DISTINCT_DRAWS = 2
DRAW_SEED_STEP = 7_000_003
#: The last progress detail of a service batch's layout whose plan the batch held, once
#: its walls were moved apart from it, or once it was laid out again (`apart_from_held`).
MOVED_APART = "the batch held this plan: walls moved apart from it"
DRAWN_AGAIN = "the batch held this plan: laid out again under another draw"
#: The summary's termination of a layout stopped at a good-enough incumbent.
GOOD_ENOUGH = "good-enough"


class BestSoFar:
    """Per brief, the lowest Eq. 12 of its good layouts so far: what the next layouts of
    the brief must come within a tolerance of to stop early (`good_enough`)."""

    def __init__(self, tolerance: float | None) -> None:
        self.tolerance = tolerance
        self._good: dict[str, list[float]] = {}

    def add(self, row: LayoutRow) -> None:
        if row.good and row.objective is not None:
            self._good.setdefault(row.brief, []).append(row.objective)

    def good_enough(self, brief: str) -> float | None:
        """The Eq. 12 at which a layout of `brief` may stop; None until the brief has
        `REFERENCE_LAYOUTS` good layouts, or without a tolerance."""
        if self.tolerance == math.inf:
            return math.inf  # the first good layout: nothing to measure it against
        found = self._good.get(brief, [])
        if self.tolerance is None or len(found) < REFERENCE_LAYOUTS:
            return None
        return min(found) * (1 + self.tolerance)


def batch_time_limit(problem: Problem) -> float:
    """The per-layout time limit of a batch when none is given."""
    return max(BATCH_MIN_SECONDS, BATCH_SECONDS_PER_ROOM * problem.room_count)


def hard_limit(time_limit: float) -> float:
    """Seconds after which a layout's process is killed."""
    return time_limit * HARD_LIMIT_FACTOR + HARD_LIMIT_GRACE


@dataclass(frozen=True)
class LayoutTask:
    """One layout of a batch: the brief (JSON as sent, a template not yet expanded), its
    seed, the per-layout time limit and what to draw at random."""

    brief: dict[str, Any]
    seed: int
    time_limit: float | None = None
    vary_program: bool = False
    #: Draw each room's target within 20 % of its own, inside its bounds (before the
    #: search draws its own within the whole bounds, options.diverse: no effect left).
    vary_sizes: bool = False
    #: Stop the solve at the first incumbent that passes the checker, covers
    #: `GOOD_COVERAGE` of the floor and has an Eq. 12 at most this (None: solve on).
    good_enough: float | None = None
    #: 0 for the layout's first solve; k for its k-th draw for a plan the batch does
    #: not hold yet (`DISTINCT_DRAWS`), solved under seed + k * `DRAW_SEED_STEP`.
    draw: int = 0

    @property
    def solved_seed(self) -> int:
        """The seed the layout is solved with (before any redraw for a good layout)."""
        return (self.seed + self.draw * DRAW_SEED_STEP) % 2**31


class LayoutRow(BaseModel):
    """A finished layout of a batch, as the summary lists it."""

    brief: str = Field(description="the brief's name (its file's stem)")
    seed: int
    file: str | None = Field(None, description="the layout's file, relative to the batch's "
                             "folder (CLI), or None")
    valid: bool = False
    coverage: float = 0.0
    objective: float | None = Field(None, description="Eq. 12 of the layout")
    time: float = Field(0.0, description="seconds the solve took")
    rooms: int = 0
    termination: str | None = None
    error: str | None = Field(None, description="why the layout failed, if it did")
    draw: int = Field(0, description="0, or with --distinct the draw that gave a plan the "
                      "batch did not hold yet (solved under seed + draw * 7000003)")
    spread: bool = Field(False, description="the solve's plan was one the batch held; its "
                         "walls were moved apart from it (solver/pipeline/spread.py)")

    @property
    def good(self) -> bool:
        return self.error is None and self.valid and self.coverage >= GOOD_COVERAGE


def task_problem(task: LayoutTask, seed: int | None = None) -> Problem:
    """The problem `task` solves: its programme (drawn or the brief's), its options;
    with `seed`, a redraw of it under that seed instead of the task's."""
    seed = task.solved_seed if seed is None else seed
    if task.vary_program:
        from floorplan.models.programme import vary_programme

        problem = vary_programme(task.brief, seed)
    else:
        problem = Problem.model_validate(task.brief)
    if task.vary_sizes and not task.vary_program:  # a drawn programme has drawn sizes
        from floorplan.models.programme import vary_sizes

        problem = vary_sizes(problem, seed)
    changes: dict[str, Any] = {"seed": seed, "diverse": True,
                               # The first good layout, whatever its Eq. 12: the solver's own.
                               "stop_when_good": task.good_enough == math.inf}
    if task.time_limit is not None:
        changes["time_limit"] = task.time_limit
    elif problem.options.time_limit is None:
        changes["time_limit"] = batch_time_limit(problem)
    return problem.with_options(**changes)


def job_problem(task: LayoutTask) -> Problem:
    """The problem of a batch's layout run as a job of the service:
    `task_problem`, laid out again whole under another draw by the solver itself when it
    ends without a good layout (`options.redraws` = `REDRAWS`, what `lay_out` does
    between solves for `floorplan batch`), its time limit the draws' total. A brief
    solved by regions or by storeys, which does not stop when good, keeps one draw and
    its limit."""
    problem = task_problem(task)
    if problem.floors is not None or problem.by_regions:
        return problem
    assert problem.options.time_limit is not None  # task_problem sets one
    return problem.with_options(redraws=REDRAWS,
                                time_limit=problem.options.time_limit * (REDRAWS + 1))


def layout_problem(brief: str, seed: int, time_limit: float | None, vary_program: bool,
                   ceiling: float) -> tuple[str, float]:
    """The problem (JSON) of the layout of a service batch solved under `seed`, and the
    job's time limit: `job_problem` of the brief (JSON as sent), its limit capped at
    `ceiling` (FLOORPLAN_MAX_TIME_LIMIT when the batch was made). The store keeps a
    batch's brief once and derives each layout's problem from it when it is read; the
    same arguments give the same problem."""
    import json

    from floorplan.service.timing import effective_time_limit

    task = LayoutTask(json.loads(brief), seed, time_limit, vary_program,
                      good_enough=math.inf)  # each job ends at its first good layout
    problem, limit = effective_time_limit(job_problem(task), ceiling)
    return problem.model_dump_json(), limit


def lay_out(task: LayoutTask) -> tuple[Problem, Layout, bool]:
    """Solve one layout of a batch (in the calling process): the problem solved, its
    layout, and whether the solve stopped at a good-enough incumbent (`GoodEnough`). A
    layout that is not good is laid out again under a redrawn seed (the sizes aimed at
    and, with `vary_program`, the programme: a drawn programme the outline cannot take
    well is drawn anew), `REDRAWS` times at most; the best of the tries is kept."""
    from floorplan.solver import solve
    from floorplan.solver.stopping import GoodEnough, good_rank

    best: tuple[Problem, Layout, bool] | None = None
    for attempt in range(REDRAWS + 1):
        problem = task_problem(task, (task.solved_seed + attempt * REDRAW_SEED_STEP) % 2**31)
        if task.good_enough is None or problem.floors is not None:
            layout, stopped = solve(problem), False
        elif problem.options.stop_when_good:
            layout = solve(problem)
            stopped = layout.report.termination is Termination.INTERRUPTED
        else:
            good = GoodEnough(problem, task.good_enough, coverage=GOOD_COVERAGE)
            layout = solve(problem, on_event=good, should_stop=good.is_reached)
            stopped = good.reached
        if best is None or good_rank(layout) > good_rank(best[1]):
            best = (problem, layout, stopped)
        if good_rank(layout)[0]:
            break
    assert best is not None
    return best


def lay_out_to_file(args: tuple[LayoutTask, str, FormatName, str]
                    ) -> tuple[dict[str, Any], str, str]:
    """`lay_out` then write the layout to `path` in `fmt` (write then rename): the task of a
    `floorplan batch` worker. Returns the summary row (as JSON data), the layout JSON,
    for the distinct-plan count, and the problem solved's JSON, for `spread_to_file`."""
    task, path, fmt, name = args
    started = time.monotonic()
    problem, layout, stopped_early = lay_out(task)
    target = _write(problem, layout, path, fmt)
    row = row_of(name, task.seed, layout, time.monotonic() - started, file=target.name)
    row.draw = task.draw
    if stopped_early:
        row.termination = GOOD_ENOUGH
    return row.model_dump(mode="json"), layout.model_dump_json(), problem.model_dump_json()


@dataclass(frozen=True)
class SpreadTask:
    """A good layout of a batch whose plan the batch holds already, to be moved apart
    from the plans near it (`others`: `solver.distinct` grids) by `spread_to_file`."""

    problem: str  #: the problem solved, JSON
    layout: str  #: its layout, JSON
    row: dict[str, Any]  #: its summary row, JSON data
    others: Any  #: numpy array, one row a plan's grid (`DistinctPlans.near`)
    path: str
    fmt: FormatName


def spread_to_file(task: SpreadTask) -> tuple[dict[str, Any], str] | None:
    """The layout of `task` with its walls moved apart from `task.others`
    (solver/pipeline/spread.py), written to `task.path` in `task.fmt`, with its summary
    row (the solve's time plus the move's) and JSON; None when it cannot be moved so
    far. The task of a `floorplan batch` worker."""
    from floorplan.solver.pipeline.spread import spread_layout

    started = time.monotonic()
    problem = Problem.model_validate_json(task.problem)
    row = LayoutRow.model_validate(task.row)
    moved = spread_layout(problem, Layout.model_validate_json(task.layout), task.others,
                          seed=row.seed)
    if moved is None:
        return None
    target = _write(problem, moved, task.path, task.fmt)
    r = moved.report
    row = row.model_copy(update={
        "file": target.name, "valid": r.valid, "coverage": round(r.coverage, 6),
        "objective": None if r.objective is None else round(r.objective, 6),
        "time": round(row.time + time.monotonic() - started, 4), "spread": True})
    return row.model_dump(mode="json"), moved.model_dump_json()


def apart_from_held(problem: Problem, layout: Layout, held: Sequence[str], *,
                    again: Callable[[Problem], Layout] | None = None
                    ) -> tuple[Layout, str | None]:
    """A service batch's layout (solved from `problem`) made a plan the batch's finished
    layouts `held` (JSON) do not hold, when it is good and theirs: its walls moved apart
    from them, as `floorplan batch` moves a repeated plan (`spread_to_file`); failing
    that, with `again`, laid out anew by `again` under another draw (seed +
    `DRAW_SEED_STEP`, as `floorplan batch --distinct` draws) and kept when that gives a
    new plan, moved apart if need be. Returns the layout and what was done (None: it
    stands as solved). Run in the solve's process."""
    from floorplan.solver.distinct import DistinctPlans

    if not _good(layout):
        return layout, None
    plans = DistinctPlans(graphs=False)
    for text in held:
        plans.add(Layout.model_validate_json(text))
    if plans.is_new(layout):
        return layout, None
    if (moved := _moved_apart(problem, layout, plans)) is not None:
        return moved, MOVED_APART
    if again is not None:
        redrawn = problem.with_options(seed=(problem.options.seed + DRAW_SEED_STEP) % 2**31)
        other = again(redrawn)
        if _good(other) and plans.is_new(other):
            return other, DRAWN_AGAIN
        if _good(other) and (moved := _moved_apart(redrawn, other, plans)) is not None:
            return moved, DRAWN_AGAIN
    return layout, None


def _moved_apart(problem: Problem, layout: Layout, plans: DistinctPlans) -> Layout | None:
    """`layout` with its walls moved apart from the plans of `plans` near it, when that
    makes it a good layout of a new plan."""
    from floorplan.solver.distinct import NEAR_SHARE
    from floorplan.solver.pipeline.spread import spread_layout

    moved = spread_layout(problem, layout, plans.near(layout, NEAR_SHARE),
                          seed=problem.options.seed)
    return moved if moved is not None and _good(moved) and plans.is_new(moved) else None


def _good(layout: Layout) -> bool:
    """Good as `solver.stopping.good_rank` ranks it, with rooms (as `row_of` counts)."""
    from floorplan.solver.stopping import good_rank

    return good_rank(layout)[0] and bool(layout.all_rooms)


def _write(problem: Problem, layout: Layout, path: str, fmt: FormatName) -> Path:
    """`layout` written to `path` in `fmt`, whole or not at all (write then rename)."""
    if fmt == "json":
        data = (layout.model_dump_json(indent=2) + "\n").encode()
    else:
        from floorplan.solver.export import render

        data = render(problem, layout, fmt)
    target = Path(path)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        tmp.write_bytes(data)
        tmp.replace(target)
    finally:
        tmp.unlink(missing_ok=True)
    return target


def row_of(name: str, seed: int, layout: Layout, seconds: float,
           file: str | None = None) -> LayoutRow:
    r = layout.report
    return LayoutRow(brief=name, seed=seed, file=file, valid=r.valid and bool(layout.all_rooms),
                     coverage=round(r.coverage, 6),
                     objective=None if r.objective is None else round(r.objective, 6),
                     time=round(seconds, 4), rooms=len(layout.all_rooms),
                     termination=r.termination.value)


class BatchSummary(BaseModel):
    """A batch's counts: layouts done, valid, failed, distinct plans and adjacency
    graphs, throughput."""

    layouts: int = Field(0, description="layouts finished (failed ones included)")
    valid: int = Field(0, description="valid layouts covering at least 99 % of the floor")
    failed: int = Field(0, description="layouts that failed (error, crash, hard limit)")
    distinct_plans: int = Field(0, description="geometrically distinct plans among the "
                                "layouts (solver.distinct: at most 5 % of the floor differs)")
    distinct_graphs: int = Field(0, description="distinct room adjacency graphs")
    redraws: int = Field(0, description="solves of this run that laid a good layout out "
                         "again for a plan the batch did not hold (`floorplan batch "
                         "--distinct`)")
    spread: int = Field(0, description="layouts of the batch whose solve gave a plan it held, "
                        "made a new plan by moving their walls apart from it")
    seconds: float = Field(0.0, description="wall-clock seconds of this run")
    rate: float = Field(0.0, description="layouts per second in this run")
    rows: list[LayoutRow] = Field(default_factory=list)


class Tally:
    """A running `BatchSummary`: rows and layouts added as they finish."""

    def __init__(self) -> None:
        from floorplan.solver.distinct import DistinctPlans

        self.rows: list[LayoutRow] = []
        self.plans = DistinctPlans()
        self.redraws = 0

    def add(self, row: LayoutRow, layout: Layout | None) -> None:
        self.rows.append(row)
        if layout is not None and row.error is None and layout.all_rooms:
            self.plans.add(layout)

    def summary(self, seconds: float, done_here: int) -> BatchSummary:
        rows = sorted(self.rows, key=lambda r: (r.brief, r.seed))
        return BatchSummary(
            layouts=len(rows), valid=sum(r.good for r in rows),
            failed=sum(r.error is not None for r in rows),
            distinct_plans=self.plans.plans, distinct_graphs=self.plans.graphs,
            redraws=self.redraws, spread=sum(r.spread for r in rows),
            seconds=round(seconds, 3), rate=round(done_here / seconds, 3) if seconds else 0.0,
            rows=rows)
