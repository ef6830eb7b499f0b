"""Fixed rooms and design variants, on the real SCIP: fixed rooms come back exactly as
given with the rest laid out around them, an impossible set of fixed rooms is explained,
and variants are valid, of distinct topologies and ranked.

The time limits are generous (slow machines); nothing asserts on wall time."""

from __future__ import annotations

import copy
import itertools
import json
from typing import Any

import pytest
from shapely.geometry import Polygon

from floorplan.models import Layout, Problem, Termination
from floorplan.solver import solve
from floorplan.solver.pipeline.variants import topology
from tests.paths import ROOT

APARTMENT: dict[str, Any] = json.loads((ROOT / "examples" / "apartment-5.json").read_text())
#: The committed answer to apartment-5: its rooms' polygons serve as fixed rooms.
ANSWER: dict[str, Any] = json.loads(
    (ROOT / "examples" / "apartment-5.layout.json").read_text())
POLYGONS = {r["id"]: r["polygon"] for r in ANSWER["rooms"]}
#: Fixed rooms must come back to this (metres).
EXACT = 1e-4


def brief(time_limit: float, **fixed: list[list[float]]) -> Problem:
    data = copy.deepcopy(APARTMENT)
    data["options"] = {"time_limit": time_limit}
    for room in data["rooms"]:
        if room["id"] in fixed:
            room["fixed"] = fixed[room["id"]]
    return Problem.model_validate(data)


def polygon_of(layout: Layout, room_id: str) -> Polygon:
    return Polygon(next(r.polygon for r in layout.rooms if r.id == room_id))


def test_fixed_rooms_are_kept_exactly_and_the_rest_laid_out_around_them() -> None:
    # Three of five rooms fixed where the committed answer has them; the kitchen and
    # the bathroom stay free.
    fixed = {k: POLYGONS[k] for k in ("living", "bedroom", "foyer")}
    layout = solve(brief(40, **fixed))
    assert layout.report.valid, layout.report
    assert layout.report.termination is not Termination.NO_SOLUTION
    for room_id, polygon in fixed.items():
        placed = polygon_of(layout, room_id)
        assert placed.symmetric_difference(Polygon(polygon)).area < EXACT
        xs = sorted({round(x, 6) for x, _ in placed.exterior.coords})
        assert xs == sorted({round(x, 6) for x, _ in polygon})
    # The fixed rooms' own constraints and their adjacencies were checked.
    kinds = {(c.kind, tuple(c.rooms)) for c in layout.report.constraints}
    assert ("adjacency", ("foyer", "living")) in kinds
    assert ("boundary", ("living",)) in kinds
    assert layout.report.coverage > 0.9


@pytest.mark.slow
def test_an_l_shaped_fixed_room_is_kept_exactly() -> None:
    bedroom = [[0, 3.3], [3.9, 3.3], [3.9, 5.1], [4.5, 5.1], [4.5, 8], [0, 8]]
    layout = solve(brief(40, bedroom=bedroom))
    assert layout.report.valid, layout.report
    placed = polygon_of(layout, "bedroom")
    assert placed.symmetric_difference(Polygon(bedroom)).area < EXACT
    for other in layout.rooms:
        if other.id != "bedroom":
            assert Polygon(other.polygon).intersection(placed).area < EXACT


def test_fixed_rooms_that_leave_no_room_for_the_rest_are_explained() -> None:
    # The living room over three quarters of the floor: the bedroom (2.8 m deep at
    # least) cannot fit into the 2 m left.
    layout = solve(brief(30, living=[[0, 0], [10.5, 0], [10.5, 6], [0, 6]]))
    assert not layout.rooms
    assert layout.report.termination is Termination.INFEASIBLE
    assert layout.report.infeasibility is not None
    assert "living" in layout.report.infeasibility.reason
    # The conflict names the fixed room by its `fixed` field, not by the size and
    # corners that hold it there.
    conflict = layout.report.infeasibility.conflict
    assert conflict is not None
    assert "rooms.1.fixed" in [item.path for item in conflict.constraints]
    assert all(item.kind != "min_size" or item.rooms != ["living"]
               for item in conflict.constraints)


@pytest.mark.slow
def test_variants_are_valid_distinct_and_ranked() -> None:
    problem = brief(5).with_options(variants=3)
    layout = solve(problem)
    variants = layout.variants
    assert variants is not None and len(variants) >= 2, "no second topology found"
    assert all(v.report.valid and v.variants is None for v in variants)
    graphs = [topology(v) for v in variants]
    assert all(a != b for a, b in itertools.combinations(graphs, 2))
    objectives = [v.report.objective for v in variants]
    assert objectives == sorted(objectives)  # type: ignore[type-var]
    # The first is the layout itself.
    assert variants[0].rooms == layout.rooms
    assert layout.report.objective == objectives[0]
    for i, v in enumerate(variants):
        info = v.report.variant
        assert info is not None and info.index == i
        assert info.difference[i] == 0
        assert all(d > 0 for j, d in enumerate(info.difference) if j != i)
        assert info.adjacencies == sorted(graphs[i])
    assert layout.report.variant is not None and layout.report.variant.least_difference


def test_one_variant_is_an_ordinary_solve() -> None:
    assert solve(brief(2)).variants is None
