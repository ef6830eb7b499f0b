"""A neighbourhood step (`_solve_neighbourhood`) starts SCIP from the layout as it stands,
computed in closed form: the model holds that start before its one solve, with the
objective Eq. 12 gives at those boxes; a layout the step's model refuses is answered
without any solve."""

from __future__ import annotations

import time

import pytest

from floorplan.solver.geometry import Box
from floorplan.solver.heuristics.neighbourhood import _solve_neighbourhood
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import LevelResult, LevelStatus, run_level
from floorplan.solver.miqp.spec import ContactSpec, LevelSpec, RectSpec, level_objective

REGION = Box(0, 0, 6, 4)
ROOMS = ("a", "b", "c", "d")
#: Four rooms in a 6 x 4 floor, short of their targets: a step can grow them.
LAYOUT = {"a": Box(0, 0, 2.5, 2), "b": Box(3, 0, 6, 2), "c": Box(0, 2, 3, 4),
          "d": Box(3, 2, 5.5, 4)}


def spec() -> LevelSpec:
    return LevelSpec(
        name="four", region=REGION, blocked=(), free_area=REGION.area,
        rects=tuple(RectSpec(n, n, min_size=(1, 1), target=(3, 2), aspect_ratio=(1, 3))
                    for n in ROOMS),
        contacts=(ContactSpec("ac", ("a",), (("c",),), 1.0),),
    )


class Recorder:
    """A step that notes what the model held before SCIP ran, then solves it."""

    def __init__(self) -> None:
        self.calls: list[tuple[int, list[float], LevelSpec]] = []

    def __call__(self, lm: LevelModel, limit: float) -> LevelResult:
        m = lm.model
        self.calls.append((m.getNSols(), [m.getSolObjVal(s) for s in m.getSols()], lm.spec))
        return run_level(lm, time_limit=limit)


def test_a_step_starts_from_the_layout_in_closed_form() -> None:
    step = Recorder()
    candidate, result = _solve_neighbourhood(spec(), LAYOUT, {"a", "b"}, (),
                                             time.monotonic() + 5, step)
    [(stored, objectives, sub)] = step.calls
    # One start stored before the one solve: the layout itself, priced as Eq. 12 at it.
    assert stored == 1
    assert objectives[0] == pytest.approx(level_objective(sub, LAYOUT), abs=1e-9)
    assert result.status is LevelStatus.OPTIMAL
    assert result.objective is not None and result.objective <= objectives[0] + 1e-9
    assert candidate["c"] == LAYOUT["c"] and candidate["d"] == LAYOUT["d"]
    assert level_objective(spec(), candidate) < level_objective(spec(), LAYOUT)


def test_a_layout_the_step_refuses_is_answered_without_a_solve() -> None:
    # a stands half a metre from c: the step's model (c held fixed) refuses the contact.
    moved = LAYOUT | {"a": Box(0, 0, 2.5, 1.5)}
    step = Recorder()
    candidate, result = _solve_neighbourhood(spec(), moved, {"a", "b"}, (),
                                             time.monotonic() + 5, step)
    assert step.calls == []
    assert result.status is LevelStatus.INFEASIBLE and result.rects is None
    assert candidate == moved
