"""Validation grows with the problem, not with its square (a 1,000-vertex outline grown
once per region, obstacles tried pairwise and once per position). Counted in shapely's
geometry operations, not timed: how long it takes is the bench's."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from typing import Any

import pytest
from pydantic import ValidationError
from shapely.geometry.base import BaseGeometry

from floorplan.models import Problem

#: The operations on one geometry that a pairwise or per-region validation repeats.
OPERATIONS = ("buffer", "intersection", "intersects", "contains", "within", "distance")


@pytest.fixture
def operations(monkeypatch: pytest.MonkeyPatch) -> Counter[str]:
    """How many times each of `OPERATIONS` runs: counted, then done as before."""
    counts: Counter[str] = Counter()

    def counted(name: str, method: Callable[..., Any]) -> Callable[..., Any]:
        def wrapper(self: BaseGeometry, *args: Any, **kwargs: Any) -> Any:
            counts[name] += 1
            return method(self, *args, **kwargs)
        return wrapper

    for name in OPERATIONS:
        monkeypatch.setattr(BaseGeometry, name, counted(name, getattr(BaseGeometry, name)))
    return counts


def staircase(steps: int = 499) -> list[list[int]]:
    n = steps
    return ([[0, 0], [n, 0]]
            + [p for i in range(n - 1) for p in ([n - i, i + 1], [n - i - 1, i + 1])]
            + [[1, n], [0, n]])


def test_many_regions_on_a_long_outline_validate_in_a_moment(
        operations: Counter[str]) -> None:
    regions = [{"id": f"g{i}", "rooms": ["r0"], "positions": [[1, 1]]} for i in range(5000)]
    problem = {"boundary": staircase(), "rooms": [{"id": "r0"}], "regions": regions}
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(problem)
    # The outline grown a few times in all (6 s when it was grown for each region;
    # 24 s for 20,000 regions), the regions' positions each tested once.
    assert operations["buffer"] <= 5, operations
    assert operations["contains"] <= len(regions) + 10, operations
    assert {e["type"] for e in caught.value.errors()} == {"room_in_two_regions"}
    assert len(Problem.model_validate({**problem, "regions": regions[:1]}).regions or []) == 1


def test_many_obstacles_and_positions_validate_in_a_moment_and_still_find_faults(
        operations: Counter[str]) -> None:
    obstacles = [{"x": i % 40 * 2 + 0.2, "y": i // 40 * 2 + 0.2, "width": 1, "depth": 1}
                 for i in range(1000)]
    obstacles.append({"x": 0.5, "y": 0.5, "width": 1, "depth": 1})  # overlaps obstacle 0
    rooms = [{"id": f"r{i}", "positions": [[i % 80 + 0.5, i // 80 * 2 + 1.9], [99, 99]]}
             for i in range(399)] + [{"id": "inside", "positions": [[0.7, 0.7]]}]
    problem = {"boundary": [[0, 0], [100, 0], [100, 100], [0, 100]], "rooms": rooms,
               "obstacles": obstacles[:1000]}
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(problem)
    # About one test per obstacle and per position (10 s when every pair was tried: a
    # million tests); the pairs that may overlap are looked up in an index.
    positions = sum(len(room["positions"]) for room in rooms)
    assert sum(operations.values()) <= 3 * (len(obstacles) + positions), operations
    assert [e["type"] for e in caught.value.errors()] == ["point_in_obstacle"]
    problem["obstacles"] = [*obstacles[:999], obstacles[-1]]
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(problem)
    assert "obstacle 999 overlaps obstacle 0" in [e["msg"] for e in caught.value.errors()]
