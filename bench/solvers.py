"""The three solvers the benchmark compares, each run once on a problem.

Every runner returns a `Trace`: the layouts it produced over time (incumbents as they
arrive, or the annealer's periodic snapshots), its final layout and its wall time, all
on the harness's own clock started just before the solver is called (model building
included). Nothing is checked while a solver runs: the checker would slow it down, so
`bench.evaluate` checks the recorded layouts afterwards.
"""

from __future__ import annotations

import os
import re
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

from pyscipopt import SCIP_EVENTTYPE, Model
from shapely.geometry import Polygon

from bench.anneal import Annealer
from floorplan.models import Problem
from floorplan.solver import solve
from floorplan.solver.budget import default_time_limit
from floorplan.solver.events import Phase, SolveEvent
from floorplan.solver.geometry import Box, make_domain
from floorplan.solver.heuristics.level_one import level_one_spec
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import MEMORY_LIMIT_MB
from floorplan.solver.pipeline.pool import subdomain_pool
from floorplan.solver.pipeline.subdomains import SubdomainExecutor

Rooms = dict[str, list[Box]]

#: The flat baseline and the annealer get this many times our time limit ...
BASELINE_FACTOR = 10.0
#: ... capped by the `--flat-limit` option, by default at this many seconds.
BASELINE_CAP = 60.0
#: How a sub-domain solved in a pool reports its own wall time.
SOLVED_IN = re.compile(r" in ([0-9.]+) s$")
#: Seconds between the annealer's snapshots of its best layout.
ANNEAL_SNAPSHOT_EVERY = 0.1


@dataclass
class Trace:
    """What one run of one solver produced."""

    solver: str
    time_limit: float
    #: (seconds since the start, whole layout) for every incumbent or snapshot, in order.
    layouts: list[tuple[float, Rooms]] = field(default_factory=list)
    final: Rooms | None = None
    #: Wall time until the solver returned its final layout.
    seconds: float = 0.0
    status: str = ""
    extra: dict[str, float | int | str] = field(default_factory=dict)
    #: The final layout's aisles (ours, through regions): part of the plan, so the
    #: checker counts them as covered floor, for every recorded layout of the run.
    aisles: list[Polygon] = field(default_factory=list)
    #: Region id -> its rooms, for the aisle checks (empty without regions).
    regions: dict[str, list[str]] = field(default_factory=dict)


def our_limit(problem: Problem) -> float:
    """The time limit `solve` uses for `problem`."""
    return problem.options.time_limit or default_time_limit(len(problem.rooms))


def baseline_limit(problem: Problem, cap: float = BASELINE_CAP) -> float:
    """Ten times our limit, at most `cap` seconds."""
    return min(BASELINE_FACTOR * our_limit(problem), cap)


def run_ours(problem: Problem, *, seed: int, cap: float = BASELINE_CAP,
             subdomain_processes: int = 1, name: str | None = None) -> Trace:
    """`solver.solve` at the problem's default time limit; with
    `subdomain_processes` > 1, each refinement level's sub-domains solved at once in a
    process pool of that many (started and warmed up before the clock starts, as the
    service's waiting solve processes start theirs before their job comes)."""
    problem = problem.with_options(seed=seed)
    name = name or ("ours" if subdomain_processes <= 1 else "ours-parallel")
    trace = Trace(name, our_limit(problem))
    pool = subdomain_pool(subdomain_processes, warmed=True)
    levels: list[float] = []  # when each refinement level started
    ends: list[float] = []  # when each sub-domain's result was applied
    solved: list[str] = []
    started = time.monotonic()

    def on_event(event: SolveEvent) -> None:
        if event.phase is Phase.INCUMBENT and event.rooms is not None:
            trace.layouts.append((time.monotonic() - started, event.rooms))
        elif event.phase is Phase.LEVEL and event.level >= 2:
            levels.append(event.elapsed)
        elif event.phase is Phase.SUBDOMAIN:
            ends.append(event.elapsed)
            solved.append(event.detail)

    try:
        layout = solve(problem, on_event=on_event, subdomains=SubdomainExecutor(
            pool, subdomain_processes) if pool is not None else None)
        trace.seconds = time.monotonic() - started
    finally:
        if pool is not None:  # after the clock: tasks past their level's end finish first
            pool.shutdown(cancel_futures=True)
    trace.status = str(layout.report.termination)
    if layout.rooms:
        trace.final = {r.id: [Box.of(rect) for rect in r.rectangles] for r in layout.rooms}
        trace.layouts.append((trace.seconds, trace.final))
    trace.aisles = [Polygon(a.polygon) for a in layout.aisles]
    for room in layout.rooms:
        if room.region is not None:
            trace.regions.setdefault(room.region, []).append(room.id)
    if layout.aisles:  # the share of rooms with a door straight onto an aisle
        through = next((c.rooms for c in layout.report.constraints
                        if c.kind == "aisle_access"), [])
        trace.extra["aisle_access"] = round(1 - len(through) / max(1, len(layout.rooms)), 3)
        trace.extra["aisle_area"] = round(sum(a.area for a in layout.aisles), 1)
    trace.extra["levels"] = layout.report.levels
    # The hierarchy's share: sub-domains solved, and the wall time of the levels.
    trace.extra["subdomains_solved"] = sum(
        1 for d in solved if ": optimal" in d or ": feasible" in d)
    trace.extra["subdomains_tried"] = len(solved)
    trace.extra["refine_seconds"] = round(ends[-1] - levels[0], 3) if levels and ends else 0.0
    if pool is not None:  # solve seconds of the sub-domains, as their reports give them
        trace.extra["subdomain_seconds"] = round(sum(
            float(m.group(1)) for d in solved if (m := SOLVED_IN.search(d))), 3)
    return trace


def run_ours_parallel(problem: Problem, *, seed: int, cap: float = BASELINE_CAP) -> Trace:
    """`run_ours` with a pool of one process per core for the sub-domains."""
    return run_ours(problem, seed=seed, cap=cap,
                    subdomain_processes=max(2, os.cpu_count() or 1))


def flat_model(problem: Problem) -> LevelModel:
    """Level 1 of the paper as one SCIP model: every constraint family, the objective of
    Eq. 12 through the epigraph, the user's own size bounds; SCIP's default settings.
    Obstacles are blocked as the paper has them: no room wraps around one."""
    domain = make_domain(problem)
    return build_level(level_one_spec(problem, domain, window=None, wrap=False))


def run_flat(problem: Problem, *, seed: int, cap: float = BASELINE_CAP) -> Trace:
    """The flat baseline: `flat_model` solved by SCIP with its defaults (only the time
    and memory limits and the random seed set), no start, no hierarchy."""
    limit = baseline_limit(problem, cap)
    trace = Trace("flat", limit)
    started = time.monotonic()
    lm = flat_model(problem)
    trace.extra["build_seconds"] = round(time.monotonic() - started, 3)
    m = lm.model
    m.setParam("limits/time", limit)
    m.setParam("limits/memory", MEMORY_LIMIT_MB)
    m.setParam("randomization/randomseedshift", seed)

    def best_solution(model: Model, _event: object) -> None:
        sol = model.getBestSol()
        trace.layouts.append((time.monotonic() - started, _read(model, sol, lm)))

    m.attachEventHandlerCallback(best_solution, [SCIP_EVENTTYPE.BESTSOLFOUND],
                                 name="bench-incumbents")
    m.optimize()
    trace.seconds = time.monotonic() - started
    trace.status = m.getStatus()
    if m.getNSols() > 0:
        trace.final = _read(m, m.getBestSol(), lm)
        # The best solution at the end is the last incumbent; keep the final time exact.
        trace.layouts.append((trace.seconds, trace.final))
    trace.extra.update(nodes=m.getNNodes(), solutions=m.getNSols(), gap=m.getGap(),
                       variables=m.getNVars(), constraints=m.getNConss())
    m.freeProb()
    return trace


def _read(model: Model, sol: object, lm: LevelModel) -> Rooms:
    rooms: Rooms = {}
    for name, v in lm.rects.items():
        x, y = model.getSolVal(sol, v.x), model.getSolVal(sol, v.y)
        rooms[name] = [Box(x, y, x + model.getSolVal(sol, v.w), y + model.getSolVal(sol, v.d))]
    return rooms


def run_anneal(problem: Problem, *, seed: int, cap: float = BASELINE_CAP) -> Trace:
    """Simulated annealing (bench/anneal.py) for as long as the flat baseline."""
    limit = baseline_limit(problem, cap)
    trace = Trace("anneal", limit)
    started = time.monotonic()
    annealer = Annealer(problem, make_domain(problem), seed=seed)
    result = annealer.run(limit - (time.monotonic() - started),
                          snapshot_every=ANNEAL_SNAPSHOT_EVERY)
    trace.seconds = time.monotonic() - started
    offset = trace.seconds - result.seconds  # set-up time before the search's own clock
    trace.layouts = [(s.elapsed + offset, s.rooms) for s in result.snapshots]
    trace.final = result.rooms
    trace.status = "timelimit"
    trace.extra.update(moves=result.moves, accepted=result.accepted,
                       last_improvement=result.last_improvement + offset)
    return trace


def run_ours_long(problem: Problem, *, seed: int, cap: float = BASELINE_CAP) -> Trace:
    """`run_ours` given the baselines' time limit (`baseline_limit`) instead of its own:
    what the extra time buys, against the flat model at equal time."""
    limited = problem.with_options(time_limit=baseline_limit(problem, cap))
    return run_ours(limited, seed=seed, cap=cap, name="ours-long")


Runner = Callable[..., Trace]
SOLVERS: dict[str, Runner] = {"ours": run_ours, "ours-parallel": run_ours_parallel,
                               "ours-long": run_ours_long, "flat": run_flat,
                               "anneal": run_anneal}


def run_guarded(solver: str, problem: Problem, *, seed: int, cap: float,
                log: Callable[[str], None]) -> Trace:
    """`SOLVERS[solver]` on `problem`; a solver's exception is a result (a trace with
    an error status and the solver's limit, its traceback sent to `log`), not the end
    of the benchmark."""
    try:
        return SOLVERS[solver](problem, seed=seed, cap=cap)
    except Exception as err:
        log(traceback.format_exc())
        limit = (our_limit(problem) if solver in ("ours", "ours-parallel")
                 else baseline_limit(problem, cap))
        return Trace(solver, limit, status=f"error: {type(err).__name__}: {err}")
