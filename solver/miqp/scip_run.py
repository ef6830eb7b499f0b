"""Running one level's SCIP model: starts, limits, seed, progress events, stopping, results."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from enum import StrEnum

from pyscipopt import SCIP_EVENTTYPE, SCIP_PARAMSETTING, Model

from floorplan.solver.geometry import Box
from floorplan.solver.miqp.model import Boxes, LevelModel

#: SCIP's memory limit per solve in MiB: below a worker's budget so SCIP stops cleanly.
MEMORY_LIMIT_MB = 4096
#: Relative gap at which a level counts as solved; layouts gain nothing visible below it.
GAP_LIMIT = 1e-3
#: Starting solutions SCIP may hold for one model.
MAX_STARTS = 100_000


class LevelStatus(StrEnum):
    OPTIMAL = "optimal"
    FEASIBLE = "feasible"  # stopped at a limit with an incumbent
    INFEASIBLE = "infeasible"
    NO_SOLUTION = "no_solution"  # stopped at a limit without one
    INTERRUPTED = "interrupted"


@dataclass(frozen=True)
class Incumbent:
    """A new best solution of the level being solved."""

    objective: float
    dual_bound: float
    elapsed: float
    rects: dict[str, Box]


@dataclass(frozen=True)
class LevelResult:
    status: LevelStatus
    rects: dict[str, Box] | None
    objective: float | None
    dual_bound: float | None
    seconds: float
    values: dict[str, float] | None = None  # every variable of the best solution, by name

    @property
    def has_solution(self) -> bool:
        return self.rects is not None


def warm_start(lm: LevelModel, values: Mapping[str, float]) -> None:
    """Hand SCIP a starting solution by variable name: a complete one when `values`
    names every variable, else a partial one that SCIP's completesol heuristic fills."""
    m = lm.model
    variables = m.getVars()
    complete = all(var.name in values for var in variables)
    sol = m.createSol() if complete else m.createPartialSol()
    for var in variables:
        if var.name in values:
            m.setSolVal(sol, var, values[var.name])
    # Starts pile up over the steps of a neighbourhood search; SCIP keeps 10 by default.
    m.setParam("limits/maxorigsol", MAX_STARTS)
    m.addSol(sol)


@contextmanager
def fixed_rects(lm: LevelModel, boxes: Mapping[str, Box]) -> Iterator[None]:
    """Fix the named rectangles at `boxes` for the solves inside the block; on exit the
    model is back in its problem stage with the original bounds."""
    m = lm.model
    saved = []
    for name, b in boxes.items():
        v = lm.rects[name]
        for var, value in ((v.x, b.x0), (v.y, b.y0), (v.w, b.width), (v.d, b.depth)):
            lb, ub = var.getLbOriginal(), var.getUbOriginal()
            saved.append((var, lb, ub))
            # Clamp: a value a hair outside its bound (SCIP's tolerance) must not invert it.
            value = min(max(value, lb), ub)
            m.chgVarLb(var, value)
            m.chgVarUb(var, value)
    try:
        yield
    finally:
        m.freeTransform()
        for var, lb, ub in saved:
            m.chgVarLb(var, lb)
            m.chgVarUb(var, ub)


def start_values(lm: LevelModel, boxes: Boxes) -> dict[str, float]:
    """Every variable's value, by name, at `boxes` (each free rectangle's; a fixed one
    is where the spec holds it): x, y, w, d, and the rest as the families registered
    (`LevelModel.derive`). Raises ValueError when a rectangle has no box, or a variable
    no valuation (a family that forgot to register one)."""
    every = _every_box(lm, boxes)
    values: dict[str, float] = {}
    for name, v in lm.rects.items():
        b = every[name]
        values.update({v.x.name: b.x0, v.y.name: b.y0, v.w.name: b.width, v.d.name: b.depth})
    for var, value in lm.derived:
        values[var.name] = value(every)
    if len(values) != lm.model.getNVars():
        unknown = sorted(v.name for v in lm.model.getVars() if v.name not in values)
        raise ValueError(f"no valuation for {', '.join(unknown[:5])}")
    return values


def _every_box(lm: LevelModel, boxes: Boxes) -> dict[str, Box]:
    """Each rectangle of `lm` at its box in `boxes`, a fixed one where the spec holds it
    (whatever `boxes` says: its variables' bounds are that box)."""
    every = {name: b for name, b in boxes.items() if name in lm.rects}
    every.update({r.name: r.fixed for r in lm.spec.rects if r.fixed is not None})
    if missing := sorted(set(lm.rects) - set(every)):
        raise ValueError(f"no box for {', '.join(missing)}")
    return every


def add_start(lm: LevelModel, boxes: Boxes) -> LevelResult:
    """Hand SCIP the full solution at `boxes` (`start_values`) as a start when it is
    feasible for `lm`, which SCIP checks (bounds, integrality, every constraint, to its
    tolerance); no solve. The result says which: FEASIBLE with the start's objective
    and values, or INFEASIBLE without (the boxes break a constraint: a start refused)."""
    started = time.monotonic()
    m = lm.model
    values = start_values(lm, boxes)
    sol = m.createSol()  # in the problem stage: a solution of the original problem
    for var in m.getVars():
        m.setSolVal(sol, var, values[var.name])
    feasible = m.checkSol(sol, printreason=False, original=True)
    objective = m.getSolObjVal(sol)
    if not feasible:
        m.freeSol(sol)
        return LevelResult(LevelStatus.INFEASIBLE, None, None, None,
                           time.monotonic() - started)
    # Starts pile up over the steps of a neighbourhood search; SCIP keeps 10 by default.
    m.setParam("limits/maxorigsol", MAX_STARTS)
    m.addSol(sol)
    return LevelResult(LevelStatus.FEASIBLE, _every_box(lm, boxes), objective, None,
                       time.monotonic() - started, values)


def complete_start(lm: LevelModel, boxes: Mapping[str, Box], *, time_limit: float) -> LevelResult:
    """Solve `lm` with the rectangles of `boxes` fixed, which leaves SCIP only the other
    rectangles, the binaries and the auxiliaries to set; the result is a full starting
    solution (or a proof that `boxes` is not feasible), handed to the model as a start.
    Only for a start that places some rectangles and not others (an edit's start with
    fewer rectangles than the wings tried, `pipeline.edit`): a full one is computed in
    closed form (`add_start`). SCIP's own completion of a partial solution gives up
    when a model has hundreds of unknown binaries."""
    with fixed_rects(lm, boxes):
        result = run_level(lm, time_limit=time_limit)
    if result.values is not None:
        warm_start(lm, result.values)
    return result


def run_level(
    lm: LevelModel,
    *,
    time_limit: float,
    seed: int = 0,
    on_incumbent: Callable[[Incumbent], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> LevelResult:
    """Solve `lm` within `time_limit` seconds and read back every rectangle."""
    m = lm.model
    m.setParam("limits/time", max(time_limit, 0.05))
    m.setParam("limits/memory", MEMORY_LIMIT_MB)
    m.setParam("limits/gap", GAP_LIMIT if lm.gap is None else lm.gap)
    m.setParam("randomization/randomseedshift", seed)
    m.setParam("timing/clocktype", 2)  # wall clock: the user's time limit is wall time
    tune(m, aggressive=lm.aggressive)
    started = time.monotonic()
    _install_hooks(lm)
    lm.hooks.update(on_incumbent=on_incumbent, should_stop=should_stop, started=started)
    m.optimize()
    seconds = time.monotonic() - started
    status = _status(m)
    rects = None
    if m.getNSols() > 0 and status is not LevelStatus.INFEASIBLE:
        rects = _read_rects(m, m.getBestSol(), lm)
    objective = m.getSolObjVal(m.getBestSol()) if rects is not None else None
    dual = m.getDualbound() if m.getStatus() != "infeasible" else None
    values = None
    if rects is not None:
        sol = m.getBestSol()
        values = {var.name: m.getSolVal(sol, var) for var in m.getVars()}
    m.freeTransform()  # back to the problem stage: bounds may change and it may run again
    return LevelResult(status, rects, objective, dual, seconds, values)


def _read_rects(m: Model, sol: object, lm: LevelModel) -> dict[str, Box]:
    rects = {}
    for name, v in lm.rects.items():
        x, y = m.getSolVal(sol, v.x), m.getSolVal(sol, v.y)
        rects[name] = Box(x, y, x + m.getSolVal(sol, v.w), y + m.getSolVal(sol, v.d))
    return rects


def tune(m: Model, *, aggressive: bool = False) -> None:
    """Settings measured on our level models (docs/method.md, "Incumbents, time and SCIP
    settings"; bench/NOTES.md, "What profiles show"): the NLP heuristics find nothing
    the LP-based ones miss on these convex MIQPs and cost most of the time, and fast
    presolving and separation prove optimality 5-20x sooner on small levels. With
    `aggressive`, SCIP's primal heuristics run more often and longer."""
    if aggressive:
        m.setHeuristics(SCIP_PARAMSETTING.AGGRESSIVE)
    for heuristic in ("subnlp", "nlpdiving", "mpec"):
        m.setParam(f"heuristics/{heuristic}/freq", -1)
    m.setSeparating(SCIP_PARAMSETTING.FAST)
    m.setPresolve(SCIP_PARAMSETTING.FAST)
    # Stopping is ours (`should_stop`); SCIP's Ctrl-C handling would end only the model
    # being solved, and its counter is shared by every SCIP in the process.
    m.setParam("misc/catchctrlc", False)


_STATUS = {
    "optimal": LevelStatus.OPTIMAL,
    "gaplimit": LevelStatus.OPTIMAL,
    "infeasible": LevelStatus.INFEASIBLE,
    "userinterrupt": LevelStatus.INTERRUPTED,
}


def _status(m: Model) -> LevelStatus:
    """SCIP's status string becomes our enum here, once."""
    raw = m.getStatus()
    if raw in _STATUS:
        return _STATUS[raw]
    return LevelStatus.FEASIBLE if m.getNSols() > 0 else LevelStatus.NO_SOLUTION


def _install_hooks(lm: LevelModel) -> None:
    """Event handlers that call whatever `lm.hooks` holds during the current solve."""
    if lm.hooks.get("installed"):
        return
    lm.hooks["installed"] = True
    hooks = lm.hooks

    def best_solution(model: Model, _event: object) -> None:
        report = hooks.get("on_incumbent")
        if report is not None:
            # getPrimalbound() can be stale inside BESTSOLFOUND; read the solution itself.
            sol = model.getBestSol()
            report(Incumbent(
                objective=model.getSolObjVal(sol),
                dual_bound=model.getDualbound(),
                elapsed=time.monotonic() - hooks["started"],
                rects=_read_rects(model, sol, lm),
            ))

    def maybe_stop(model: Model, _event: object) -> None:
        should_stop = hooks.get("should_stop")
        # interruptSolve returns within milliseconds and keeps the incumbent.
        if should_stop is not None and should_stop():
            model.interruptSolve()

    m = lm.model
    m.attachEventHandlerCallback(best_solution, [SCIP_EVENTTYPE.BESTSOLFOUND], name="incumbents")
    m.attachEventHandlerCallback(
        maybe_stop, [SCIP_EVENTTYPE.NODESOLVED, SCIP_EVENTTYPE.LPSOLVED], name="stopper"
    )
