"""Soft constraints: with `options.strict: false`, or `soft` on a room or an adjacency,
an over-constrained problem gets the layout of least total shortfall, every violated
constraint listed with it, instead of no layout. Real SCIP throughout."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from typing import Any

import httpx2 as httpx
import pytest
from pydantic import ValidationError

from floorplan.models import Layout, Problem, Termination
from floorplan.service.cli.progress import summary_line
from floorplan.solver import solve
from floorplan.solver.geometry import Box, make_domain
from floorplan.solver.heuristics.level_one import level_one_spec
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.scip_run import LevelStatus, run_level
from floorplan.solver.miqp.spec import level_objective, spec_shortfall
from floorplan.solver.verify.checker import check_layout
from floorplan.solver.verify.precheck import find_impossibilities
from tests.paths import ROOT
from tests.servers import Server
from tests.solver.verify.test_conflicts import CHAIN, CONTRADICTIONS, CROWDED, OUT_OF_REACH

# A real brief that asks too much: a flat 6 m wide along its only facade (south) and
# 12 m deep, whose living room, kitchen and both bedrooms, all rectangles, want that
# facade. Their smallest widths add up to 11.6 m (as L-shaped rooms each could reach
# the facade with a narrower arm).
NARROW_FLAT: dict[str, Any] = {
    "name": "narrow-flat",
    "boundary": [[0, 0], [6, 0], [6, 12], [0, 12]],
    "rooms": [
        {"id": "living", "type": "living", "min_size": [3.5, 3.5], "target_size": [4, 4.5],
         "boundary": ["south"], "max_rects": 1},
        {"id": "kitchen", "type": "kitchen", "min_size": [2.4, 2.4], "target_size": [2.6, 3],
         "boundary": ["south"], "max_rects": 1},
        {"id": "bed1", "type": "bedroom", "min_size": [3, 3], "target_size": [3.2, 3.6],
         "boundary": ["south"], "max_rects": 1},
        {"id": "bed2", "type": "bedroom", "min_size": [2.7, 3], "target_size": [3, 3.4],
         "boundary": ["south"], "max_rects": 1},
        {"id": "bath", "type": "bathroom", "min_size": [1.8, 2], "max_size": [3, 3]},
    ],
    "adjacency": [{"a": "kitchen", "b": "living"}],
    "options": {"time_limit": 4, "strict": False},
}

#: Layouts that plainly meet every hard constraint, made by hand; their total shortfall,
#: as the checker measures it, bounds what the solver may return.
OBVIOUS: dict[str, dict[str, list[Box]]] = {
    # Study and bed share the 3 m north edge at 1.5 m each: 0.5 m short each.
    "north-wing": {"living": [Box(2, 0, 8, 5)], "study": [Box(0, 5, 1.5, 9)],
                   "bed": [Box(1.5, 5, 3, 9)], "bath": [Box(0, 0, 2, 2)]},
    # The dining room 6 m wide between the other two: 3 m over its maximum.
    "chain": {"living": [Box(0, 1.5, 3, 4)], "dining": [Box(3, 0, 9, 4)],
              "kitchen": [Box(9, 0, 12, 4)], "bath": [Box(0, 0, 1.5, 1.5)]},
    # The office 9 m wide from the point to the east wall: 5 m over its maximum.
    "out-of-reach": {"office": [Box(1, 0, 10, 4)], "store": [Box(0, 4, 4, 6)]},
    # The hall 3 x 5: its long side 1 m short of twice the short one.
    "ratio": {"hall": [Box(0, 0, 3, 5)], "wc": [Box(3, 0, 5, 2)]},
    # Both large rooms 2.75 m wide, the small one 0.5 m wide at its point.
    "crowded": {"a": [Box(0, 0, 2.75, 4)], "b": [Box(2.75, 0, 5.5, 4)],
                "c": [Box(5.5, 0, 6, 1)]},
    # Everyone on the facade, squeezed to 1.5 m wide: 11.6 - 6 = 5.6 m short.
    "narrow-flat": {"living": [Box(0, 0, 1.5, 4)], "kitchen": [Box(1.5, 0, 3, 4)],
                    "bed1": [Box(3, 0, 4.5, 4)], "bed2": [Box(4.5, 0, 6, 4)],
                    "bath": [Box(0, 4, 2, 6)]},
}
OVER_CONSTRAINED = {name: raw for name, (raw, _) in CONTRADICTIONS.items()} | {
    "narrow-flat": NARROW_FLAT}


def soft(raw: dict[str, Any], **options: Any) -> Problem:
    return Problem.model_validate(
        raw | {"options": raw.get("options", {}) | {"strict": False} | options})


def hand_bound(problem: Problem, rooms: dict[str, list[Box]]) -> float:
    check = check_layout(problem, rooms)
    hard = [c for c in check.constraints if not c.satisfied and not c.soft
            and c.kind != "coverage"]
    assert not hard, hard  # the hand layout is a plan
    return sum(c.shortfall for c in check.constraints if c.soft and not c.satisfied)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(OVER_CONSTRAINED))
def test_an_over_constrained_problem_gets_the_layout_of_least_shortfall(name: str) -> None:
    problem = soft(OVER_CONSTRAINED[name], time_limit=60, seed=1)
    bound = hand_bound(problem, OBVIOUS[name])
    assert bound > 0
    report = solve(problem).report
    assert report.termination is not Termination.INFEASIBLE
    assert report.valid  # every hard constraint holds
    assert [c for c in report.constraints if not c.satisfied and not c.soft
            and c.kind != "coverage"] == []
    assert report.violations and all(c.soft and not c.satisfied and c.shortfall > 0
                                     for c in report.violations)
    assert report.violations == [c for c in report.constraints if c.soft and not c.satisfied]
    assert report.total_shortfall == pytest.approx(sum(c.shortfall for c in report.violations),
                                                   abs=1e-5)
    assert report.total_shortfall <= bound + 1e-3


@pytest.mark.slow
def test_the_narrow_flat_keeps_its_rooms_and_says_who_lost_the_facade() -> None:
    report = solve(soft(NARROW_FLAT, seed=1)).report
    assert report.valid and report.coverage > 0.9
    kinds = {c.kind for c in report.violations}
    assert kinds <= {"size", "boundary", "adjacency"} and kinds & {"size", "boundary"}
    # Every room is a real room, not squeezed to nothing.
    sizes = [c for c in report.constraints if c.kind == "connected"]
    assert len(sizes) == 5 and all(c.satisfied for c in sizes)


def test_a_soft_adjacency_that_cannot_hold_gives_way_while_the_hard_ones_hold() -> None:
    # 'west' and 'east' sit on opposite walls 10 m apart, each at most 3 m wide: they
    # cannot touch; the middle room must touch both.
    problem = Problem.model_validate({
        "boundary": [[0, 0], [10, 0], [10, 4], [0, 4]],
        "rooms": [
            {"id": "west", "min_size": [2, 2], "max_size": [3, 4], "boundary": ["west"]},
            {"id": "middle", "min_size": [2, 2]},
            {"id": "east", "min_size": [2, 2], "max_size": [3, 4], "boundary": ["east"]},
        ],
        "adjacency": [{"a": "west", "b": "east", "soft": True},
                      {"a": "middle", "b": "west"}, {"a": "middle", "b": "east"}],
        "options": {"time_limit": 3},
    })
    assert find_impossibilities(problem, make_domain(problem)) == []
    report = solve(problem).report
    assert report.valid
    [violation] = report.violations
    assert violation.kind == "adjacency" and violation.rooms == ["west", "east"]
    # The rooms are at least 10 - 3 - 3 = 4 m apart.
    assert violation.shortfall >= 4 - 1e-3
    others = [c for c in report.constraints if c is not violation and c.kind != "coverage"]
    assert all(c.satisfied and not c.soft for c in others)


@pytest.mark.slow
def test_a_room_softens_only_the_families_it_lists() -> None:
    # The office may miss its point, but its maximum width and east wall stay hard.
    raw = json.loads(json.dumps(OUT_OF_REACH))
    raw["rooms"][0]["soft"] = ["positions"]
    report = solve(Problem.model_validate(raw)).report
    assert report.valid
    [violation] = report.violations
    assert violation.kind == "position" and violation.rooms == ["office"]
    # At most 4 m wide against the east wall at x = 10: x >= 6, 5 m from x = 1.
    assert violation.shortfall == pytest.approx(5.0, abs=1e-3)
    size = next(c for c in report.constraints if c.kind == "size" and c.rooms == ["office"])
    assert size.satisfied and not size.soft


def test_soft_families_are_checked_by_name() -> None:
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(CHAIN | {"rooms": [{"id": "a", "soft": ["width"]}],
                                        "adjacency": []})
    assert caught.value.errors()[0]["loc"][:3] == ("rooms", 0, "soft")


@pytest.mark.slow
def test_a_feasible_problem_gets_the_same_layout_in_soft_mode() -> None:
    raw = json.loads((ROOT / "examples" / "apartment-5.json").read_text())
    strict = solve(Problem.model_validate(raw))
    relaxed = solve(soft(raw))
    assert strict.report.valid and relaxed.report.valid
    assert relaxed.report.violations == [] and relaxed.report.total_shortfall == 0
    # The same plan: SCIP's limits are wall-clock, so the last digits may differ.
    def corners(layout: Layout) -> list[float]:
        return [v for r in layout.rooms for q in r.rectangles
                for v in (q.x, q.y, q.width, q.depth)]

    assert corners(relaxed) == pytest.approx(corners(strict), abs=0.05)
    assert relaxed.report.objective == pytest.approx(strict.report.objective, rel=0.02)


def test_strict_stays_the_default_and_explains_the_conflict() -> None:
    layout = solve(Problem.model_validate(CHAIN))
    assert layout.report.termination is Termination.INFEASIBLE and not layout.rooms
    assert layout.report.infeasibility is not None
    assert layout.report.infeasibility.conflict is not None


def test_prechecks_refuse_nothing_for_a_soft_constraint() -> None:
    strict = Problem.model_validate(CROWDED)
    assert find_impossibilities(strict, make_domain(strict))
    relaxed = soft(CROWDED)
    assert find_impossibilities(relaxed, make_domain(relaxed)) == []


@pytest.mark.parametrize("name", sorted(OVER_CONSTRAINED))
def test_the_miqp_prices_violations_as_the_python_side_measures_them(name: str) -> None:
    problem = soft(OVER_CONSTRAINED[name])
    spec = level_one_spec(problem, make_domain(problem), window=None, soft=True)
    # What is compared is the objective of the layout SCIP returns, optimal or not: on a
    # loaded machine 3 s may end before the proof.
    result = run_level(build_level(spec), time_limit=3)
    assert result.status in (LevelStatus.OPTIMAL, LevelStatus.FEASIBLE)
    assert result.rects is not None
    assert result.objective == pytest.approx(level_objective(spec, result.rects), rel=1e-3,
                                             abs=1e-3)
    assert spec_shortfall(spec, result.rects) > 0


@pytest.mark.slow
def test_the_summary_line_counts_soft_violations() -> None:
    layout = solve(soft(CHAIN))
    line = summary_line(layout)
    assert f"soft violations {len(layout.report.violations)}" in line
    assert f"({layout.report.total_shortfall:.2f} m short)" in line


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("soft"), WORKERS="1").start()
    yield s
    s.stop()


@pytest.mark.slow
def test_the_service_validates_and_solves_a_soft_problem(server: Server) -> None:
    body = CROWDED | {"options": {"time_limit": 3, "strict": False}}
    with httpx.Client(base_url=server.url, timeout=30) as client:
        cheap = client.post("/v1/validate", json=body).json()
        assert cheap["valid"] and cheap["findings"] == []
        assert cheap["problem"]["options"]["strict"] is False
        explained = client.post("/v1/validate?explain=true&time_limit=5", json=body).json()
        assert explained["valid"] and explained["feasible"] is True
        job = client.post("/v1/layouts", json=body).json()
        deadline = time.monotonic() + 30
        while (info := client.get(f"/v1/layouts/{job['id']}").json())["status"] not in (
                "succeeded", "failed", "canceled"):
            assert time.monotonic() < deadline
            time.sleep(0.1)
        assert info["status"] == "succeeded"
        layout = Layout.model_validate(client.get(f"/v1/layouts/{job['id']}/result").json())
    assert layout.report.valid and layout.report.violations
    assert layout.report.total_shortfall > 0


@pytest.mark.slow
def test_a_templated_problem_too_full_for_its_floors_is_solved_when_not_strict() -> None:
    raw = {"boundary": [[0, 0], [9, 0], [9, 7], [0, 7]], "entrance": [4.5, 0],
           "template": "residential",
           "rooms": ["living", "kitchen", *["bedroom"] * 9, "bathroom"]}
    with pytest.raises(ValidationError):
        Problem.model_validate(raw)
    problem = Problem.model_validate(raw | {"options": {"strict": False, "time_limit": 4}})
    assert find_impossibilities(problem, make_domain(problem)) == []
    report = solve(problem).report
    assert report.valid and report.violations and report.total_shortfall > 0
