"""Explained conflicts (solver/verify/conflicts.py): contradictory problems get a small set of
their constraints that cannot hold together. Each set is checked here independently of
the search, on SCIP's level-1 model: the set alone is infeasible, and without any one
of its members it is not."""

from __future__ import annotations

import itertools
import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from floorplan.models import ConflictSet, Problem, Termination
from floorplan.solver import solve
from floorplan.solver.geometry import make_domain
from floorplan.solver.heuristics.level_one import level_one_spec
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.scip_run import LevelStatus, run_level
from floorplan.solver.verify.conflicts import Verdict, deletion_filter, diagnose, find_conflict
from tests.paths import ROOT
from tests.servers import Server

#: Seconds SCIP gets for each independent check of a set.
CHECK_SECONDS = 5.0

# Two rectangular rooms must touch the 3 m north edge of an L-shaped flat's north
# wing, each at least 2 m wide: they cannot sit side by side (as L-shaped rooms they
# could, each reaching the edge with a narrower arm). The living room and the bathroom,
# with their own demands, are bystanders.
NORTH_WING: dict[str, Any] = {
    "name": "north-wing",
    "boundary": [[0, 0], [8, 0], [8, 5], [3, 5], [3, 9], [0, 9]],
    "rooms": [
        {"id": "living", "type": "living", "min_size": [3, 3], "max_size": [6, 5],
         "target_size": [5, 4], "positions": [[6, 1]], "boundary": ["south"]},
        {"id": "study", "type": "office", "min_size": [2, 2], "max_size": [3, 4],
         "boundary": [4], "max_rects": 1},
        {"id": "bed", "type": "bedroom", "min_size": [2, 2.5], "max_size": [3, 4],
         "boundary": [4], "max_rects": 1},
        {"id": "bath", "type": "bathroom", "min_size": [1.5, 1.5], "max_size": [2.5, 2.5],
         "aspect_ratio": [1, 1.5]},
    ],
    "adjacency": [{"a": "bath", "b": "living"}],
    "options": {"time_limit": 3},
}

# A 12 m wide house 4 m deep: the kitchen on the east wall, the living room on the
# west wall, the dining room between touching both, none wider than 3 m.
CHAIN: dict[str, Any] = {
    "name": "chain",
    "boundary": [[0, 0], [12, 0], [12, 4], [0, 4]],
    # Rectangles only: SCIP proves one rectangle per room infeasible in a fraction of a
    # second, but L-shaped rooms (whose size bounds hold on their boxes just the same)
    # take it longer than a test's time limit on a slow machine.
    "rooms": [
        {"id": "kitchen", "type": "kitchen", "min_size": [2, 2], "max_size": [3, 4],
         "boundary": ["east"], "max_rects": 1},
        {"id": "dining", "type": "dining", "min_size": [2, 2], "max_size": [3, 4],
         "max_rects": 1},
        {"id": "living", "type": "living", "min_size": [2, 2], "max_size": [3, 4],
         "boundary": ["west"], "max_rects": 1},
        {"id": "bath", "type": "bathroom", "min_size": [1.5, 1.5], "max_size": [2.5, 2.5],
         "max_rects": 1},
    ],
    "adjacency": [{"a": "kitchen", "b": "dining"}, {"a": "dining", "b": "living"},
                  {"a": "bath", "b": "living"}],
    "options": {"time_limit": 3},
}

# A room at most 4 m wide must cover a point 1 m from the west wall and lie along
# the east wall, 10 m away.
OUT_OF_REACH: dict[str, Any] = {
    "name": "out-of-reach",
    "boundary": [[0, 0], [10, 0], [10, 6], [0, 6]],
    "rooms": [
        {"id": "office", "min_size": [2, 2], "max_size": [4, 6], "positions": [[1, 3]],
         "boundary": ["east"]},
        {"id": "store", "min_size": [2, 2], "max_size": [4, 4], "boundary": ["north"]},
    ],
    "adjacency": [{"a": "office", "b": "store", "min_contact": 1.0}],
    "options": {"time_limit": 3},
}

# Sides of at least 3 m with the long one 2-3 times the short one need 6 m: more than
# the 5 m square has. No precheck sees it (each bound alone allows the ratio).
RATIO_TOO_LONG: dict[str, Any] = {
    "name": "ratio",
    "boundary": [[0, 0], [5, 0], [5, 5], [0, 5]],
    "rooms": [
        {"id": "hall", "type": "hall", "min_size": [3, 3], "aspect_ratio": [2, 3]},
        {"id": "wc", "type": "wc", "min_size": [1, 1], "max_size": [2, 2]},
    ],
    "options": {"time_limit": 3},
}

# 32 m² of rooms in 24 m²: the prechecks say so; the conflict names the sizes.
CROWDED: dict[str, Any] = {
    "name": "crowded",
    "boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
    "rooms": [{"id": "a", "min_size": [4, 4]}, {"id": "b", "min_size": [4, 4]},
              {"id": "c", "max_size": [1, 1], "positions": [[5.5, 0.5]]}],
    "options": {"time_limit": 3},
}

CONTRADICTIONS = {
    "north-wing": (NORTH_WING, {"study", "bed"}),
    "chain": (CHAIN, {"kitchen", "dining", "living"}),
    "out-of-reach": (OUT_OF_REACH, {"office"}),
    "ratio": (RATIO_TOO_LONG, {"hall"}),
    "crowded": (CROWDED, {"a", "b"}),
}


# Independent of solver/verify/conflicts.py: constraints by path, and SCIP's verdict.


def only(problem: Problem, paths: set[str]) -> Problem:
    """`problem` with no constraint but those at `paths`; every room stays."""
    data = problem.model_dump()
    for i, room in enumerate(data["rooms"]):
        for field, free in (("min_size", 0.0), ("max_size", 1e5)):
            if room[field] is None:
                continue
            kept = [f"rooms.{i}.{field}" in paths or f"rooms.{i}.{field}.{axis}" in paths
                    for axis in range(2)]
            room[field] = [v if k else free for v, k in zip(room[field], kept, strict=True)]
        if f"rooms.{i}.aspect_ratio" not in paths:
            room["aspect_ratio"] = None
        room["positions"] = [p for k, p in enumerate(room["positions"])
                             if f"rooms.{i}.positions.{k}" in paths]
        if f"rooms.{i}.boundary" not in paths:
            room["boundary"] = []
        room["target_size"] = None
    data["adjacency"] = [a for k, a in enumerate(data["adjacency"]) if f"adjacency.{k}" in paths]
    return Problem.model_validate(data)


def level_one(problem: Problem) -> LevelStatus:
    """SCIP on the level-1 model: one rectangle per room, the user's bounds."""
    spec = level_one_spec(problem, make_domain(problem), window=None)
    return run_level(build_level(spec, feasibility=True), time_limit=CHECK_SECONDS).status


def assert_irreducible(problem: Problem, conflict: ConflictSet) -> None:
    paths = {c.path for c in conflict.constraints}
    assert len(paths) == len(conflict.constraints)
    assert level_one(only(problem, paths)) is LevelStatus.INFEASIBLE
    for path in paths:
        without = level_one(only(problem, paths - {path}))
        assert without is not LevelStatus.INFEASIBLE, f"{path} is not needed"


@pytest.mark.parametrize("name", list(CONTRADICTIONS))
def test_a_contradictory_problem_gets_an_irreducible_conflict_in_words(name: str) -> None:
    data, culprits = CONTRADICTIONS[name]
    problem = Problem.model_validate(data)
    # Proved infeasible (in half a second; its 3 s limit is far above that), the search
    # for the conflict included: not given up at the limit (no_solution).
    layout = solve(problem)
    assert layout.report.termination is Termination.INFEASIBLE
    why = layout.report.infeasibility
    assert why is not None and why.conflict is not None
    conflict = why.conflict
    assert conflict.minimal
    involved = {room for c in conflict.constraints for room in c.rooms}
    assert involved == culprits
    # Every room in the conflict is named in its sentence, and so is the outline.
    for room in culprits:
        assert f"'{room}'" in conflict.explanation
    assert " m outline" in conflict.explanation
    assert_irreducible(problem, conflict)


def test_the_chain_is_explained_by_its_walls_widths_and_adjacencies() -> None:
    why = solve(Problem.model_validate(CHAIN)).report.infeasibility
    assert why is not None and why.conflict is not None
    assert [(c.path, c.constraint) for c in why.conflict.constraints] == [
        ("rooms.0.max_size.0", "kitchen.width<=3"),
        ("rooms.0.boundary", "kitchen.boundary=east"),
        ("rooms.1.max_size.0", "dining.width<=3"),
        ("rooms.2.max_size.0", "living.width<=3"),
        ("rooms.2.boundary", "living.boundary=west"),
        ("adjacency.0", "kitchen-dining>=0.9"),
        ("adjacency.1", "dining-living>=0.9"),
    ]
    assert why.conflict.explanation.startswith(
        "These 7 constraints cannot all hold in the 12 x 4 m outline with each room one "
        "rectangle: 'kitchen' must be at most 3 m wide; 'kitchen' must lie along edge 1 "
        "(east, 4 m);")


def test_constraints_that_require_connected_added_are_named_as_such() -> None:
    # The front-door room covers the entrance near the west end; the bedroom, on the
    # east wall, must have a door onto it: neither is wide enough to meet the other.
    problem = Problem.model_validate({
        "name": "connected", "boundary": [[0, 0], [10, 0], [10, 4], [0, 4]],
        "entrance": [1, 0],
        "rooms": [
            {"id": "foyer", "type": "foyer", "min_size": [1.5, 1.5], "max_size": [2, 4]},
            {"id": "bed", "type": "bedroom", "min_size": [2, 2], "max_size": [3, 4],
             "boundary": ["east"]},
        ],
        "options": {"time_limit": 3, "require_connected": True},
    })
    why = solve(problem).report.infeasibility
    assert why is not None and why.conflict is not None
    added = [c for c in why.conflict.constraints if c.path == "options.require_connected"]
    assert {c.kind for c in added} == {"connection", "entrance"}
    assert all("require_connected" in c.phrase for c in added)


# The filter itself, on an oracle that needs no SCIP.


@pytest.mark.parametrize(("needed", "most_checks"), [
    ({3, 90, 171}, 40),  # a few among many: chunks, not one check per item (200)
    (set(range(200)), 210),  # all of them: about one check each
])
def test_the_deletion_filter_finds_the_needed_items_in_few_checks(
    needed: set[int], most_checks: int,
) -> None:
    calls: list[list[int]] = []

    def verdict(active: list[int]) -> Verdict:
        calls.append(active)
        return Verdict.INFEASIBLE if needed <= set(active) else Verdict.FEASIBLE

    kept, proven = deletion_filter(list(range(200)), verdict, lambda: False)
    assert kept == sorted(needed) and proven
    assert len(calls) <= most_checks


def test_undecided_checks_and_lack_of_time_keep_items_and_say_so() -> None:
    def undecided_about_5(active: list[int]) -> Verdict:
        if {2, 5} <= set(active):
            return Verdict.INFEASIBLE
        return Verdict.UNDECIDED if 5 not in active else Verdict.FEASIBLE

    assert deletion_filter(list(range(8)), undecided_about_5, lambda: False) == ([2, 5], False)
    ticks = itertools.count()
    kept, proven = deletion_filter(list(range(8)), undecided_about_5,
                                   lambda: next(ticks) >= 1)
    assert not proven and {2, 5} <= set(kept)


def test_a_search_cut_short_still_names_constraints_that_cannot_hold() -> None:
    problem = Problem.model_validate(CHAIN)
    domain = make_domain(problem)
    assert find_conflict(problem, domain, deadline=time.monotonic()) is None
    looks = itertools.count()
    conflict = find_conflict(problem, domain, deadline=time.monotonic() + 10,
                             should_stop=lambda: next(looks) >= 3)
    assert conflict is not None and not conflict.minimal
    assert conflict.explanation.endswith("so a smaller set may exist.")
    paths = {c.path for c in conflict.constraints}
    assert level_one(only(problem, paths)) is LevelStatus.INFEASIBLE


def test_diagnose_tells_feasible_from_infeasible_without_solving() -> None:
    feasible = diagnose(Problem.model_validate({**CHAIN, "adjacency": []}), time_limit=3)
    assert feasible.feasible is True and feasible.conflict is None
    infeasible = diagnose(Problem.model_validate(OUT_OF_REACH), time_limit=3)
    assert infeasible.feasible is False and infeasible.findings == []
    assert infeasible.conflict is not None and infeasible.conflict.minimal


# The command line and the service.


@pytest.mark.slow
def test_the_command_line_prints_the_conflict_and_exits_3(tmp_path: Path) -> None:
    (tmp_path / "chain.json").write_text(json.dumps(CHAIN))
    done = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "solve", "chain.json", "-o", "layout.json"],
        cwd=tmp_path, capture_output=True, text=True, timeout=60,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert done.returncode == 3
    assert "These 7 constraints cannot all hold in the 12 x 4 m outline" in done.stderr
    assert "adjacency.1: dining-living>=0.9" in done.stderr


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("conflicts"), WORKERS="1").start()
    yield s
    s.stop()


@pytest.mark.slow
def test_the_service_explains_in_the_failed_job_and_in_validate(server: Server) -> None:
    with httpx.Client(base_url=server.url, timeout=30) as client:
        job = client.post("/v1/layouts", json=OUT_OF_REACH).json()
        deadline = time.monotonic() + 30
        while (info := client.get(f"/v1/layouts/{job['id']}").json())["status"] not in (
                "succeeded", "failed", "canceled"):
            assert time.monotonic() < deadline
            time.sleep(0.1)
        assert info["status"] == "failed" and info["error"]["code"] == "infeasible"
        conflict = info["error"]["conflict"]
        assert [c["path"] for c in conflict["constraints"]] == [
            "rooms.0.max_size.0", "rooms.0.positions.0", "rooms.0.boundary"]
        assert conflict["minimal"] and "'office'" in conflict["explanation"]

        explained = client.post("/v1/validate?explain=true&time_limit=5",
                                json=OUT_OF_REACH).json()
        assert explained["valid"] is False and explained["feasible"] is False
        assert explained["conflict"] == conflict
        # Without explain, validate stays cheap and says nothing of feasibility.
        cheap = client.post("/v1/validate", json=OUT_OF_REACH).json()
        assert cheap["valid"] and "feasible" not in cheap and "conflict" not in cheap
        fine = client.post("/v1/validate?explain=true",
                           json={**OUT_OF_REACH, "rooms": OUT_OF_REACH["rooms"][1:],
                                 "adjacency": []}).json()
        assert fine["valid"] and fine["feasible"] is True and fine["conflict"] is None


@pytest.mark.slow
def test_the_python_client_hands_over_the_conflict(server: Server) -> None:
    from floorplan_client import Client, Infeasible

    with Client(server.url, api_key=None) as fp:
        with pytest.raises(Infeasible) as caught:
            # Proving it for L- and T-shaped rooms too takes SCIP about 1.8 s of the
            # 3 s on an idle machine; the service's second search shares the cores.
            fp.submit(CHAIN | {"options": {"time_limit": 8}}).wait(timeout=30)
        conflict = caught.value.conflict
        assert conflict is not None and conflict.minimal
        assert "adjacency.1" in [c.path for c in conflict.constraints]
        verdict = fp.validate(CHAIN, explain=True, time_limit=5)
        assert verdict.feasible is False and verdict.conflict == conflict
        assert fp.validate(CHAIN).feasible is None
