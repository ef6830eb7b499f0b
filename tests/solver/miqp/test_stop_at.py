"""A solve that ends at its first good-enough incumbent (`run_level(stop_at=...)`, what
each neighbourhood step asks for): SCIP is interrupted from its new-incumbent event once
an incumbent reaches `stop_at`, says FEASIBLE (not INTERRUPTED: no caller stopped it),
and seeks nothing after it; the start handed to the model never counts; a `stop_at`
below the optimum leaves the solve to prove it."""

from __future__ import annotations

from floorplan.solver.geometry import Box
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import LevelResult, LevelStatus, add_start, run_level
from floorplan.solver.miqp.spec import ContactSpec, LevelSpec, RectSpec

REGION = Box(0, 0, 6, 4)
#: Four rooms in a 6 x 4 floor, short of their targets: SCIP finds several incumbents
#: on its way to the optimum (zero size error, full cover).
LAYOUT = {"a": Box(0, 0, 2.5, 2), "b": Box(3, 0, 6, 2), "c": Box(0, 2, 3, 4),
          "d": Box(3, 2, 5.5, 4)}
#: Far above need: these solves end by optimality or by `stop_at`.
LIMIT = 120.0


def started() -> tuple[LevelModel, float]:
    """The level's model holding `LAYOUT` as its start, and the start's objective."""
    lm = build_level(LevelSpec(
        name="four", region=REGION, blocked=(), free_area=REGION.area,
        rects=tuple(RectSpec(n, n, min_size=(1, 1), target=(3, 2), aspect_ratio=(1, 3))
                    for n in LAYOUT),
        contacts=(ContactSpec("ac", ("a",), (("c",),), 1.0),),
    ))
    start = add_start(lm, LAYOUT)
    assert start.objective is not None
    return lm, start.objective


def solve(stop_at: float | None) -> tuple[LevelResult, list[float], float]:
    """The result, every incumbent's objective SCIP announced, and the start's."""
    lm, start = started()
    incumbents: list[float] = []
    result = run_level(lm, time_limit=LIMIT, stop_at=stop_at,
                       on_incumbent=lambda found: incumbents.append(found.objective))
    return result, incumbents, start


def test_a_solve_ends_at_its_first_incumbent_that_reaches_stop_at() -> None:
    whole, all_found, start = solve(None)
    assert whole.status is LevelStatus.OPTIMAL and whole.objective is not None
    stop_at = start - 0.01
    assert len([o for o in all_found if o <= stop_at]) >= 2  # more than one to skip
    result, found, _ = solve(stop_at)
    assert result.status is LevelStatus.FEASIBLE
    assert result.objective is not None and result.objective <= stop_at
    assert [o for o in found if o <= stop_at] == [found[-1]]
    assert result.rects is not None and set(result.rects) == set(LAYOUT)


def test_the_start_never_reaches_stop_at() -> None:
    # stop_at just below the start: had the start counted, the solve would end on it.
    result, found, start = solve(start_objective() - 1e-3)
    assert result.objective is not None and result.objective < start - 1e-3
    assert found and found[-1] == result.objective


def test_a_stop_at_below_the_optimum_leaves_the_solve_to_prove_it() -> None:
    result, _, _ = solve(-1.0)
    assert result.status is LevelStatus.OPTIMAL


def start_objective() -> float:
    return started()[1]
