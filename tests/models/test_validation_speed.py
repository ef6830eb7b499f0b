"""Validation grows with the problem, not with its square (a 1,000-vertex outline grown
once per region, obstacles tried pairwise and once per position)."""

from __future__ import annotations

import time

import pytest
from pydantic import ValidationError

from floorplan.models import Problem


def staircase(steps: int = 499) -> list[list[int]]:
    n = steps
    return ([[0, 0], [n, 0]]
            + [p for i in range(n - 1) for p in ([n - i, i + 1], [n - i - 1, i + 1])]
            + [[1, n], [0, n]])


def test_many_regions_on_a_long_outline_validate_in_a_moment() -> None:
    regions = [{"id": f"g{i}", "rooms": ["r0"], "positions": [[1, 1]]} for i in range(5000)]
    problem = {"boundary": staircase(), "rooms": [{"id": "r0"}], "regions": regions}
    started = time.monotonic()
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(problem)
    assert time.monotonic() - started < 2  # 6 s before; 24 s for 20,000 regions
    assert {e["type"] for e in caught.value.errors()} == {"room_in_two_regions"}
    assert len(Problem.model_validate({**problem, "regions": regions[:1]}).regions or []) == 1


def test_many_obstacles_and_positions_validate_in_a_moment_and_still_find_faults() -> None:
    obstacles = [{"x": i % 40 * 2 + 0.2, "y": i // 40 * 2 + 0.2, "width": 1, "depth": 1}
                 for i in range(1000)]
    obstacles.append({"x": 0.5, "y": 0.5, "width": 1, "depth": 1})  # overlaps obstacle 0
    rooms = [{"id": f"r{i}", "positions": [[i % 80 + 0.5, i // 80 * 2 + 1.9], [99, 99]]}
             for i in range(399)] + [{"id": "inside", "positions": [[0.7, 0.7]]}]
    problem = {"boundary": [[0, 0], [100, 0], [100, 100], [0, 100]], "rooms": rooms,
               "obstacles": obstacles[:1000]}
    started = time.monotonic()
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(problem)
    assert time.monotonic() - started < 2  # 10 s before
    assert [e["type"] for e in caught.value.errors()] == ["point_in_obstacle"]
    problem["obstacles"] = [*obstacles[:999], obstacles[-1]]
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(problem)
    assert "obstacle 999 overlaps obstacle 0" in [e["msg"] for e in caught.value.errors()]
