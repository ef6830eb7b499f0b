"""`Room.fixed` and `options.variants`: each bad fixed polygon is refused with an error
naming its field."""

from __future__ import annotations

import copy
import json
from typing import Any

import pytest
from pydantic import ValidationError

from floorplan.models import Problem
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


def test_fixed_rooms_with_floors_are_refused_naming_the_room() -> None:
    data = json.loads((ROOT / "examples" / "two-storey-house.json").read_text())
    room = data["floors"][0]["rooms"][0]
    room["fixed"] = SQUARE
    found = errors(data)
    assert (("floors", 0, "rooms", 0, "fixed"), "fixed_with_floors") in found


#: A warm start of two rooms of apartment-5, as the layout gives its rooms.
START = [{"id": "foyer", "type": "foyer", "polygon": SQUARE, "area": 9.0,
          "rectangles": [{"x": 0, "y": 0, "width": 3, "depth": 3}]},
         {"id": "kitchen", "rectangles": [{"x": 3, "y": 0, "width": 3, "depth": 3}]}]


def test_a_start_of_layout_rooms_or_of_ids_to_rectangles_is_accepted() -> None:
    data = brief()
    data["options"] = {"start": START}
    as_rooms = Problem.model_validate(data).options.start
    data["options"] = {"start": {r["id"]: r["rectangles"] for r in START}}
    as_mapping = Problem.model_validate(data).options.start
    assert as_rooms is not None and as_mapping is not None
    assert [(r.id, r.rectangles) for r in as_rooms] == [(r.id, r.rectangles)
                                                        for r in as_mapping]


@pytest.mark.parametrize(("start", "loc", "kind"), [
    ([{"id": "attic", "rectangles": [{"x": 0, "y": 0, "width": 1, "depth": 1}]}],
     ("options", "start", 0, "id"), "unknown_room"),
    ([START[1], START[1]], ("options", "start", 1, "id"), "duplicate_id"),
    ([{"id": "foyer", "rectangles": [{"x": 0, "y": 0, "width": 0, "depth": 1}]}],
     ("options", "start", 0, "rectangles", 0, "width"), "greater_than"),
    ([{"id": "foyer", "rectangles": []}], ("options", "start", 0, "rectangles"), "too_short"),
    ([{"id": "foyer", "rects": []}], ("options", "start", 0, "rectangles"), "missing"),
    ({"foyer": "here"}, ("options", "start", 0, "rectangles"), "list_type"),
    ("foyer", ("options", "start"), "list_type"),
])
def test_a_malformed_start_is_refused_naming_the_field(
        start: Any, loc: tuple[str | int, ...], kind: str) -> None:
    data = brief()
    data["options"] = {"start": start}
    assert (loc, kind) in errors(data)


def test_a_start_with_floors_is_refused() -> None:
    data = json.loads((ROOT / "examples" / "two-storey-house.json").read_text())
    data.setdefault("options", {})["start"] = {"x": [{"x": 0, "y": 0, "width": 1, "depth": 1}]}
    assert (("options", "start"), "start_with_floors") in errors(data)
