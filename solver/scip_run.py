"""Running one level's SCIP model: limits, seed, progress events, stopping, results."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum

from pyscipopt import SCIP_EVENTTYPE, Model

from solver.formulation import LevelModel
from solver.geometry import Box

#: SCIP's memory limit per solve in MiB: below a worker's budget so SCIP stops cleanly.
MEMORY_LIMIT_MB = 4096
#: Relative gap at which a level counts as solved; layouts gain nothing visible below it.
GAP_LIMIT = 1e-3


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
    """Hand SCIP a partial solution by variable name; its completesol heuristic fills in
    the rest (binaries, epigraph variables)."""
    m = lm.model
    sol = m.createPartialSol()
    for var in m.getVars():
        if var.name in values:
            m.setSolVal(sol, var, values[var.name])
    m.addSol(sol)


def rect_values(boxes: Mapping[str, Box]) -> dict[str, float]:
    """Variable values x, y, w, d of rectangles, by the names `add_rect_vars` gives."""
    values = {}
    for name, b in boxes.items():
        values.update({f"x[{name}]": b.x0, f"y[{name}]": b.y0,
                       f"w[{name}]": b.width, f"d[{name}]": b.depth})
    return values


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
    m.setParam("limits/gap", GAP_LIMIT)
    m.setParam("randomization/randomseedshift", seed)
    m.setParam("timing/clocktype", 2)  # wall clock: the user's time limit is wall time
    started = time.monotonic()
    if on_incumbent is not None:
        _on_best_solution(m, on_incumbent, started)
    if should_stop is not None:
        _stop_when(m, should_stop)
    m.optimize()
    seconds = time.monotonic() - started
    status = _status(m)
    rects = None
    if m.getNSols() > 0 and status is not LevelStatus.INFEASIBLE:
        sol = m.getBestSol()
        rects = {
            name: Box(
                m.getSolVal(sol, v.x),
                m.getSolVal(sol, v.y),
                m.getSolVal(sol, v.x) + m.getSolVal(sol, v.w),
                m.getSolVal(sol, v.y) + m.getSolVal(sol, v.d),
            )
            for name, v in lm.rects.items()
        }
    objective = m.getSolObjVal(m.getBestSol()) if rects is not None else None
    dual = m.getDualbound() if m.getStatus() != "infeasible" else None
    values = None
    if rects is not None:
        sol = m.getBestSol()
        values = {var.name: m.getSolVal(sol, var) for var in m.getVars()}
    return LevelResult(status, rects, objective, dual, seconds, values)


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


def _on_best_solution(m: Model, report: Callable[[Incumbent], None], started: float) -> None:
    def callback(model: Model, _event: object) -> None:
        # getPrimalbound() can be stale inside BESTSOLFOUND; read the solution itself.
        report(Incumbent(
            objective=model.getSolObjVal(model.getBestSol()),
            dual_bound=model.getDualbound(),
            elapsed=time.monotonic() - started,
        ))

    m.attachEventHandlerCallback(callback, [SCIP_EVENTTYPE.BESTSOLFOUND], name="incumbents")


def _stop_when(m: Model, should_stop: Callable[[], bool]) -> None:
    def callback(model: Model, _event: object) -> None:
        # interruptSolve returns within milliseconds and keeps the incumbent.
        if should_stop():
            model.interruptSolve()

    m.attachEventHandlerCallback(
        callback, [SCIP_EVENTTYPE.NODESOLVED, SCIP_EVENTTYPE.LPSOLVED], name="stopper"
    )
