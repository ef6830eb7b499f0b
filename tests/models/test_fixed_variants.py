"""`Room.fixed` and `options.variants` (issue 21): each bad fixed polygon is refused
with an error naming its field."""

from __future__ import annotations

import copy
import json
from typing import Any

import pytest
from pydantic import ValidationError

from models import Problem
from tests.paths import ROOT

APARTMENT: dict[str, Any] = json.loads((ROOT / "examples" / "apartment-5.json").read_text())
SQUARE = [[0, 0], [3, 0], [3, 3], [0, 3]]


def brief(**fixed: list[list[float]]) -> dict[str, Any]:
    """apartment-5 with the rooms named fixed at the given polygons."""
    data = copy.deepcopy(APARTMENT)
    for room in data["rooms"]:
        if room["id"] in fixed:
            room["fixed"] = fixed[room["id"]]
    return data


def errors(data: dict[str, Any]) -> list[tuple[tuple[str | int, ...], str]]:
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(data)
    return [(tuple(e["loc"]), e["type"]) for e in caught.value.errors()]


def test_an_axis_aligned_polygon_inside_is_accepted_and_a_closing_vertex_dropped() -> None:
    problem = Problem.model_validate(brief(foyer=[*SQUARE, [0, 0]]))
    assert problem.rooms[0].fixed == [tuple(map(float, p)) for p in SQUARE]


def test_an_l_shaped_polygon_is_accepted() -> None:
    shape = [[0, 0], [4, 0], [4, 2], [2, 2], [2, 4], [0, 4]]
    assert Problem.model_validate(brief(bedroom=shape)).rooms[3].fixed is not None


def test_a_slanted_edge_is_refused_at_its_vertex() -> None:
    found = errors(brief(foyer=[[0, 0], [3, 0], [3, 3], [1, 4]]))
    assert (("rooms", 0, "fixed", 2), "fixed_not_axis_aligned") in found


def test_a_polygon_outside_the_outline_is_refused() -> None:
    found = errors(brief(kitchen=[[-1, 0], [3, 0], [3, 3], [-1, 3]]))
    assert found == [(("rooms", 2, "fixed"), "fixed_outside")]


def test_a_polygon_over_an_obstacle_is_refused() -> None:
    data = brief(kitchen=SQUARE)
    data["obstacles"] = [{"x": 2, "y": 2, "width": 1, "depth": 1}]
    assert errors(data) == [(("rooms", 2, "fixed"), "fixed_over_obstacle")]


def test_a_polygon_over_another_fixed_room_is_refused() -> None:
    found = errors(brief(foyer=SQUARE, kitchen=[[2, 2], [5, 2], [5, 5], [2, 5]]))
    assert found == [(("rooms", 2, "fixed"), "fixed_overlap")]


def test_touching_fixed_rooms_are_accepted() -> None:
    Problem.model_validate(brief(foyer=SQUARE, kitchen=[[3, 0], [6, 0], [6, 3], [3, 3]]))


def test_fixed_rooms_with_regions_are_refused() -> None:
    data = brief(foyer=SQUARE)
    data["regions"] = [{"id": "all", "rooms": [r["id"] for r in data["rooms"]]}]
    assert (("rooms", 0, "fixed"), "fixed_with_regions") in errors(data)


@pytest.mark.parametrize("count", [0, 13])
def test_variants_out_of_range_are_refused(count: int) -> None:
    data = brief()
    data["options"] = {"variants": count}
    assert [loc for loc, _ in errors(data)] == [("options", "variants")]
