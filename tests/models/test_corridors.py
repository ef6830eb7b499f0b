"""The `corridors` field: accepted as documented, refused with errors naming the field."""

from __future__ import annotations

from typing import Any

import pytest
from pydantic import ValidationError

from floorplan.models import Problem

FLOOR: dict[str, Any] = {
    "boundary": [[0, 0], [30, 0], [30, 12], [0, 12]],
    "obstacles": [{"x": 14, "y": 4, "width": 2, "depth": 4, "label": "stairs"}],
    "rooms": [{"id": f"r{k}", "target_size": [4, 3]} for k in range(6)],
}


def _problem(corridors: dict[str, Any], **extra: Any) -> Problem:
    return Problem.model_validate({**FLOOR, "corridors": corridors, **extra})


def _errors(corridors: dict[str, Any], **extra: Any) -> list[tuple[tuple[Any, ...], str]]:
    with pytest.raises(ValidationError) as caught:
        _problem(corridors, **extra)
    return [(tuple(e["loc"]), e["type"]) for e in caught.value.errors()]


def test_defaults_and_spelling() -> None:
    p = _problem({"exits": [[0, 6], [30, 6]]})
    assert p.corridors is not None
    assert p.corridors.width == 1.8
    assert p.corridors.max_travel is None and p.corridors.dead_ends is None
    assert (p.corridors.weights.length, p.corridors.weights.travel) == (1.0, 1.0)
    assert p.corridors.rooms_open_onto_corridor
    assert p.by_regions  # laid out by the large-layout pipeline, any room count
    full = _problem(
        {
            "exits": [[0, 6]],
            "width": 2.0,
            "max_travel": 45,
            "dead_ends": 6,
            "weights": {"length": 2, "travel": 0.5},
            "rooms_open_onto_corridor": False,
        }
    )
    assert full.corridors is not None and full.corridors.dead_ends == 6


def test_an_exit_on_a_stair_core_is_accepted() -> None:
    p = _problem({"exits": [[14, 6]]})  # the west side of the stairs
    assert p.corridors is not None


def test_an_exit_off_the_outline_is_refused() -> None:
    assert _errors({"exits": [[0, 6], [10, 6]]}) == [
        (("corridors", "exits", 1), "exit_off_outline")
    ]


def test_an_exit_inside_an_obstacle_is_refused() -> None:
    assert (("corridors", "exits", 0), "exit_off_outline") in _errors({"exits": [[15, 6]]})


def test_a_corridor_wider_than_the_floor_is_refused() -> None:
    narrow = {**FLOOR, "boundary": [[0, 0], [30, 0], [30, 4], [0, 4]], "obstacles": []}
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate({**narrow, "corridors": {"exits": [[0, 2]], "width": 5}})
    assert [(tuple(e["loc"]), e["type"]) for e in caught.value.errors()] == [
        (("corridors", "width"), "corridor_too_wide")
    ]


@pytest.mark.parametrize(
    "bad",
    [
        {"exits": []},
        {"exits": [[0, 6]], "width": 0.5},
        {"exits": [[0, 6]], "max_travel": -1},
        {"exits": [[0, 6]], "dead_ends": float("nan")},
        {"exits": [[0, 6]], "weights": {"length": -1}},
        {"exits": [[0, 6]], "speed": 3},
    ],
)
def test_bad_values_name_their_field(bad: dict[str, Any]) -> None:
    locs = [loc for loc, _ in _errors(bad)]
    assert locs and all(loc[0] == "corridors" for loc in locs)


def test_corridors_with_regions_are_refused() -> None:
    regions = [{"id": "a", "rooms": ["r0", "r1"]}]
    assert (("corridors",), "corridors_with_regions") in _errors(
        {"exits": [[0, 6]]}, regions=regions
    )


def test_routes_are_accepted_as_documented() -> None:
    p = _problem({"exits": [[0, 6]], "routes": [
        {"between": [[2, 2], [28, 10]], "max_walk": 40}, {"between": [[0, 6], [30, 6]]}]})
    assert p.corridors is not None
    first, second = p.corridors.routes
    assert first.between == ((2, 2), (28, 10)) and first.max_walk == 40
    assert second.max_walk is None
    assert _problem({"exits": [[0, 6]]}).corridors.routes == []  # type: ignore[union-attr]


def test_a_route_point_off_the_floor_or_in_an_obstacle_is_refused() -> None:
    assert _errors({"exits": [[0, 6]], "routes": [{"between": [[15, 6], [40, 6]]}]}) == [
        (("corridors", "routes", 0, "between", 0), "route_off_floor"),
        (("corridors", "routes", 0, "between", 1), "route_off_floor"),
    ]


def test_a_route_shorter_than_its_points_allow_is_explained() -> None:
    # 26 m along x and 8 along y: no walk along corridors is shorter than 34 m.
    with pytest.raises(ValidationError) as caught:
        _problem({"exits": [[0, 6]], "routes": [{"between": [[2, 2], [28, 10]],
                                                  "max_walk": 30}]})
    (error,) = caught.value.errors()
    assert error["loc"] == ("corridors", "routes", 0, "max_walk")
    assert error["type"] == "route_too_short" and "34 m" in error["msg"]
