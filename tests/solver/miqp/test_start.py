"""Starts in closed form (`scip_run.add_start`): every variable of a level's MIQP follows
from the rectangles' boxes, and SCIP checks the full solution without solving. For each
constraint family a tiny level with boxes that satisfy it gives a start SCIP accepts,
whose objective is Eq. 12 with the soft shortfalls as `spec.level_objective` computes
them; boxes that break the family are refused. Boxes of SCIP's own solutions, feasible
only to its tolerance, are accepted too."""

from __future__ import annotations

from dataclasses import replace

import pytest

from floorplan.solver.geometry import Box, Notch
from floorplan.solver.heuristics.variety import pull_to_anchors
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.objective import e_band_shortfall
from floorplan.solver.miqp.scip_run import (
    LevelResult,
    LevelStatus,
    add_start,
    run_level,
    start_values,
)
from floorplan.solver.miqp.spec import (
    ContactSpec,
    EnvelopeSpec,
    LevelSpec,
    Refine,
    level_objective,
)
from tests.solver.miqp.levels import L_BLOCKED, L_EDGES, TIME_LIMIT, level, rect
from tests.solver.miqp.test_objective import full_spec

#: The start's objective is SCIP's evaluation of the same expressions.
OBJ_TOL = 1e-9
#: A price per metre of soft violation, so that slacks show in the objective.
PRICE = 10.0

CENTRE_BLOCK = Box(2, 1, 4, 3)
#: A shaft in the north-west corner; a room may enclose it with a margin beyond it.
SHAFT = Notch(obstacle=Box(0, 3, 1, 4), hull=Box(0, 2.5, 1.5, 4))


def start(spec: LevelSpec, boxes: dict[str, Box]) -> LevelResult:
    """The closed-form start of the level's full model (every family, Eq. 12)."""
    return add_start(build_level(spec), boxes)


def assert_accepted(spec: LevelSpec, boxes: dict[str, Box]) -> None:
    result = start(spec, boxes)
    assert result.status is LevelStatus.FEASIBLE
    assert result.values is not None and result.rects is not None
    assert result.objective == pytest.approx(level_objective(spec, result.rects), abs=OBJ_TOL)


def assert_refused(spec: LevelSpec, boxes: dict[str, Box]) -> None:
    result = start(spec, boxes)
    assert result.status is LevelStatus.INFEASIBLE
    assert result.values is None and result.rects is None and result.objective is None


def soft(spec: LevelSpec) -> LevelSpec:
    return replace(spec, violation_weight=PRICE)


# One case per family: (spec, boxes that satisfy it, boxes that break it).
CASES: dict[str, tuple[LevelSpec, dict[str, Box], dict[str, Box]]] = {
    "size": (level(rect("a", min_size=(1, 1), max_size=(3, 3), target=(2, 2))),
             {"a": Box(0, 0, 2.5, 3)}, {"a": Box(0, 0, 4, 2)}),
    "inside": (level(rect("a")), {"a": Box(1, 0, 6, 4)}, {"a": Box(1, 0, 6.5, 4)}),
    "blocked": (level(rect("a"), blocked=[CENTRE_BLOCK]),
                {"a": Box(0, 1, 2, 3)}, {"a": Box(1.5, 0.5, 2.5, 1.5)}),
    "notch-clear": (replace(level(rect("a")), notches=(SHAFT,)),
                    {"a": Box(1, 0, 6, 4)}, {"a": Box(0, 2, 3, 3.5)}),
    "notch-wrapped": (replace(level(rect("a")), notches=(SHAFT,)),
                      {"a": Box(0, 0, 3, 4)}, {"a": Box(0, 0, 1.2, 4)}),
    "notch-no-wrap": (replace(level(rect("a", may_wrap=False)), notches=(SHAFT,)),
                      {"a": Box(0, 0, 3, 3)}, {"a": Box(0, 0, 3, 4)}),
    "overlap-west-east": (level(rect("a"), rect("b")),
                          {"a": Box(0, 0, 3, 4), "b": Box(3, 0, 6, 4)},
                          {"a": Box(0, 0, 3.1, 4), "b": Box(3, 0, 6, 4)}),
    "overlap-east-west": (level(rect("a"), rect("b")),
                          {"a": Box(4, 1, 6, 3), "b": Box(0, 0, 4, 4)},
                          {"a": Box(3.9, 1, 6, 3), "b": Box(0, 0, 4, 4)}),
    "overlap-north-south": (level(rect("a"), rect("b"), rect("c")),
                            {"a": Box(0, 2, 6, 4), "b": Box(0, 0, 3, 2), "c": Box(3, 0, 6, 2)},
                            {"a": Box(0, 1.9, 6, 4), "b": Box(0, 0, 3, 2),
                             "c": Box(3, 0, 6, 2)}),
    "ratio-wide": (level(rect("a", aspect_ratio=(1, 2))),
                   {"a": Box(0, 0, 3, 2)}, {"a": Box(0, 0, 3, 1)}),
    "ratio-tall": (level(rect("a", aspect_ratio=(1.5, 2))),
                   {"a": Box(0, 0, 2, 3.5)}, {"a": Box(0, 0, 2, 2)}),
    "pos": (level(rect("a", positions=((1, 1), (2.5, 3)))),
            {"a": Box(0.5, 0, 3, 3)}, {"a": Box(0.5, 0, 2, 3)}),
    "boundary": (level(rect("a", edges=(L_EDGES[0], L_EDGES[3])), blocked=L_BLOCKED),
                 {"a": Box(1, 0, 3, 2)}, {"a": Box(1, 0.5, 3, 2)}),
    "boundary-notch-wall": (level(rect("a", edges=(L_EDGES[0], L_EDGES[3])),
                                  blocked=L_BLOCKED),
                            {"a": Box(2, 2, 4, 4)}, {"a": Box(1, 2, 3, 4)}),
    "adj-vertical-wall": (level(rect("a"), rect("b"),
                                contacts=[ContactSpec("ab", ("a",), (("b",),), 1.5)]),
                          {"a": Box(0, 0, 2, 2), "b": Box(2, 0.5, 4, 4)},
                          {"a": Box(0, 0, 2, 2), "b": Box(2, 1, 4, 4)}),
    "adj-horizontal-wall": (level(rect("a"), rect("b"),
                                  contacts=[ContactSpec("ab", ("a",), (("b",),), 1.5)]),
                            {"a": Box(0, 0, 2, 2), "b": Box(0.5, 2, 4, 4)},
                            {"a": Box(0, 0, 2, 2), "b": Box(0.5, 2.1, 4, 4)}),
    "adj-any-of": (level(rect("a"), rect("b"), rect("c"),
                         contacts=[ContactSpec("a-bc", ("a",), (("b",), ("c",)), 1)]),
                   {"a": Box(0, 0, 2, 2), "b": Box(3, 0, 6, 2), "c": Box(0, 2, 2, 4)},
                   {"a": Box(0, 0, 2, 2), "b": Box(3, 0, 6, 2), "c": Box(1.5, 2, 3, 4)}),
    "adj-fixed-partner": (level(rect("a"), rect("f", fixed=L_BLOCKED[0]), blocked=L_BLOCKED,
                                contacts=[ContactSpec("af", ("a",), (("f",),), 1)]),
                          {"a": Box(3, 2, 4, 4)}, {"a": Box(2, 2, 3.5, 4)}),
    "refine": (level(rect("h", target=(2, 2),
                          refine=Refine(Box(0, 0, 2, 2), "vertical", 0, 0.5))),
               {"h": Box(0, 0, 2.3, 2.4)}, {"h": Box(0, 0, 2, 1.5)}),
    "envelope": (level(rect("a", room="r"), rect("b", room="r"), envelopes=[
                     EnvelopeSpec("r", ("a", "b"), Box(0, 0, 4, 2), (5, 3), (1, 3))]),
                 {"a": Box(0, 0, 2, 2), "b": Box(2, 0, 4.5, 2.5)},
                 {"a": Box(0, 0, 2, 2), "b": Box(2, 0, 5.5, 2)}),
    "exact-envelope": (level(rect("a", room="r"), rect("b", room="r"), envelopes=[
                           EnvelopeSpec("r", ("a", "b"), None, (5, 3), (1, 2),
                                        min_size=(3, 2), positions=((3.5, 2.5),))]),
                       {"a": Box(0, 0, 2, 2), "b": Box(2, 0, 4, 3)},
                       {"a": Box(0, 0, 2, 2), "b": Box(2, 0, 4, 2.4)}),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_boxes_that_hold_give_a_start_scip_accepts(case: str) -> None:
    spec, holding, _ = CASES[case]
    assert_accepted(spec, holding)


@pytest.mark.parametrize("case", sorted(CASES))
def test_boxes_that_break_a_constraint_are_refused(case: str) -> None:
    spec, _, breaking = CASES[case]
    assert_refused(spec, breaking)


def test_a_wrapped_notch_counts_as_no_floor() -> None:
    spec, holding, _ = CASES["notch-wrapped"]
    lm = build_level(spec)
    values = start_values(lm, holding)
    assert values["wrap[a,n0]"] == 1
    assert [values[f"clear[a,n0,{s}]"] for s in range(4)] == [0, 0, 0, 0]
    clear = start_values(build_level(spec), {"a": Box(1, 0, 6, 4)})
    assert clear["wrap[a,n0]"] == 0 and clear["clear[a,n0,1]"] == 1


@pytest.mark.parametrize(
    ("family", "rect_fields", "holding", "shortfall"),
    [
        ("min_size", {"min_size": (3, 3), "floor": (1, 1)}, Box(0, 0, 2, 2.5), 1.5),
        ("max_size", {"max_size": (2, 2)}, Box(0, 0, 3, 2.5), 1.5),
        ("aspect_ratio", {"aspect_ratio": (1, 2)}, Box(0, 0, 1, 3), 1),
        ("aspect_ratio", {"aspect_ratio": (1.5, 2)}, Box(0, 0, 3, 2.5), 0.75),
        ("positions", {"positions": ((4, 3), (1, 1))}, Box(0, 0, 3, 2), 1),
        ("boundary", {"edges": (L_EDGES[0], L_EDGES[3])}, Box(1, 0.5, 3, 2), 0.5),
        ("boundary", {"edges": (L_EDGES[0], L_EDGES[3])}, Box(2, 2, 3.7, 4), 0.3),
    ],
)
def test_soft_families_start_with_their_least_slack(family: str, rect_fields: dict,
                                                     holding: Box, shortfall: float) -> None:
    spec = soft(level(rect("a", soft=frozenset({family}), **rect_fields), blocked=L_BLOCKED))
    result = start(spec, {"a": holding})
    assert result.status is LevelStatus.FEASIBLE and result.values is not None
    slacks = sum(v for name, v in result.values.items() if name.startswith("slack["))
    assert slacks == pytest.approx(shortfall)
    assert result.objective == pytest.approx(level_objective(spec, {"a": holding}), abs=OBJ_TOL)


@pytest.mark.parametrize(
    ("b_at", "shortfall"),
    [(Box(2, 0.5, 4, 4), 0.0), (Box(2.5, 1, 4, 4), 0.5), (Box(0.5, 2.3, 4, 4), 0.3)],
)
def test_a_soft_contact_starts_with_what_it_misses(b_at: Box, shortfall: float) -> None:
    spec = soft(level(rect("a"), rect("b"), rect("c"), contacts=[
        ContactSpec("ab", ("a",), (("b",), ("c",)), 1.5, soft=True)]))
    boxes = {"a": Box(0, 0, 2, 2), "b": b_at, "c": Box(4.5, 0, 6, 1)}
    result = start(spec, boxes)
    assert result.status is LevelStatus.FEASIBLE and result.values is not None
    assert result.values["slack[adj[ab]]"] == pytest.approx(shortfall)
    assert result.objective == pytest.approx(level_objective(spec, boxes), abs=OBJ_TOL)


def test_a_soft_exact_envelope_starts_with_what_it_misses() -> None:
    spec = soft(level(rect("a", room="r"), rect("b", room="r"), envelopes=[
        EnvelopeSpec("r", ("a", "b"), None, (3, 3), (1, 1.2),
                     soft=frozenset({"min_size", "max_size", "aspect_ratio"}),
                     min_size=(2, 2.5))]))
    boxes = {"a": Box(0, 0, 2, 2), "b": Box(2, 0, 4, 1)}  # a 4 x 2 bounding box
    result = start(spec, boxes)
    assert result.status is LevelStatus.FEASIBLE and result.values is not None
    # Width 4 is 1 over its maximum, depth 2 is 0.5 under its minimum, and the long
    # side 4 is 1.6 beyond 1.2 x the short one.
    assert result.values["slack[env_max_w[r]]"] == pytest.approx(1)
    assert result.values["slack[env_min_d[r]]"] == pytest.approx(0.5)
    assert result.values["slack[env_ratio[r]]"] == pytest.approx(1.6)
    assert result.objective == pytest.approx(level_objective(spec, boxes), abs=OBJ_TOL)


def test_every_family_at_once_from_scips_own_solution() -> None:
    # SCIP's boxes hold only to its tolerance; the start from them is accepted, and its
    # objective is the solution's.
    spec = full_spec()
    solved = run_level(build_level(spec), time_limit=TIME_LIMIT)
    assert solved.rects is not None and solved.objective is not None
    free = {n: b for n, b in solved.rects.items() if n != "f"}
    result = start(spec, free)
    assert result.status is LevelStatus.FEASIBLE
    assert result.objective == pytest.approx(solved.objective, rel=1e-5)
    assert result.objective == pytest.approx(level_objective(spec, solved.rects), abs=OBJ_TOL)


@pytest.mark.parametrize("case", sorted(CASES))
def test_every_family_from_scips_own_solution(case: str) -> None:
    spec = CASES[case][0]
    solved = run_level(build_level(spec), time_limit=TIME_LIMIT)
    assert solved.rects is not None
    result = start(spec, solved.rects)
    assert result.status is LevelStatus.FEASIBLE
    assert result.objective == pytest.approx(solved.objective, rel=1e-5, abs=1e-5)


def test_a_started_model_solves_from_its_start() -> None:
    spec, holding, _ = CASES["adj-any-of"]
    lm = build_level(spec)
    began = add_start(lm, holding)
    assert began.objective is not None
    assert lm.model.getNSols() == 1  # the start, stored before any solve
    solved = run_level(lm, time_limit=TIME_LIMIT)
    assert solved.status is LevelStatus.OPTIMAL
    assert solved.objective is not None and solved.objective <= began.objective + 1e-9


def test_band_shortfalls_and_anchors_have_values_too() -> None:
    spec = level(rect("a", min_size=(1, 1)), rect("b", min_size=(1, 1)))
    lm = build_level(spec, feasibility=True)
    e_band_shortfall(lm, {"a": ((2, 2), (3, 3)), "b": ((1, 1), (2, 2))})
    boxes = {"a": Box(0, 0, 1.5, 3.5), "b": Box(2, 0, 4, 2)}
    result = add_start(lm, boxes)
    assert result.objective == pytest.approx(0.5 + 0.5)
    anchored = build_level(spec)
    pull_to_anchors(anchored, seed=3)
    assert add_start(anchored, boxes).status is LevelStatus.FEASIBLE


def test_a_variable_without_a_valuation_is_an_error() -> None:
    lm = build_level(CASES["size"][0])
    lm.model.addVar("stray")
    with pytest.raises(ValueError, match="stray"):
        start_values(lm, CASES["size"][1])


def test_a_missing_rectangle_is_an_error() -> None:
    spec, holding, _ = CASES["overlap-west-east"]
    with pytest.raises(ValueError, match="no box for b"):
        start_values(build_level(spec), {"a": holding["a"]})
