"""The problem contract refuses invalid input before solving, naming the field (DESIGN.md §1),
and accepts every valid form of it."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError
from shapely.geometry import Polygon

from floorplan.models import DEFAULT_MAX_ROOMS, Problem
from tests.paths import CASES

RECTANGLE = [[0, 0], [10, 0], [10, 8], [0, 8]]
#: 10 x 8 with the north-west 4 x 2 corner cut away: a notch that is outside the domain.
L_SHAPE = [[0, 0], [10, 0], [10, 8], [4, 8], [4, 6], [0, 6]]
#: Two axis-aligned loops crossing at (1, 0): every edge is axis-aligned, the ring is not simple.
BOW_TIE = [[0, 0], [2, 0], [2, 2], [1, 2], [1, -1], [0, -1]]
#: Two squares touching at the vertex (2, 2): a ring that touches itself.
FIGURE_EIGHT = [[0, 0], [2, 0], [2, 2], [4, 2], [4, 4], [2, 4], [2, 2], [0, 2]]

Loc = tuple[str | int, ...]


def _problem(**fields: Any) -> dict[str, Any]:
    """A valid problem as JSON-like data, with top-level `fields` replaced."""
    data: dict[str, Any] = {
        "name": "test",
        "boundary": copy.deepcopy(RECTANGLE),
        "rooms": [{"id": "living", "type": "living"}, {"id": "kitchen", "type": "kitchen"}],
    }
    data.update(copy.deepcopy(fields))
    return data


def _rooms(*rooms: dict[str, Any]) -> list[dict[str, Any]]:
    """`rooms` followed by a plain 'kitchen', so adjacency tests have a second room."""
    return [*rooms, {"id": "kitchen"}]


def _refusal(data: dict[str, Any], context: dict[str, Any] | None = None) -> list[Any]:
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(data, context=context)
    return caught.value.errors()


def _assert_refused(data: dict[str, Any], loc: Loc, kind: str | None = None,
                    context: dict[str, Any] | None = None) -> None:
    errors = _refusal(data, context)
    found = [e for e in errors if tuple(e["loc"]) == loc]
    assert found, f"no error at {loc}; got {[(e['loc'], e['type']) for e in errors]}"
    if kind is not None:
        assert kind in {e["type"] for e in found}
    assert all(e["msg"] for e in found)


# Refused input, one case per kind; each names the field at fault.

INVALID: list[Any] = [
    pytest.param(_problem(boundary=[[0, 0], [10, 0], [10, 8], [1, 9]]), ("boundary", 2),
                 "not_axis_aligned", id="boundary-not-axis-aligned"),
    pytest.param(_problem(boundary=BOW_TIE), ("boundary",), "self_intersecting",
                 id="boundary-bow-tie"),
    pytest.param(_problem(boundary=FIGURE_EIGHT), ("boundary",), "self_intersecting",
                 id="boundary-touches-itself"),
    pytest.param(_problem(boundary=[[0, 0], [10, 0], [10, 0], [10, 8], [0, 8]]), ("boundary", 1),
                 "degenerate_edge", id="boundary-repeated-vertex"),
    pytest.param(_problem(boundary=[[0, 0], [1, 0], [2, 0], [3, 0]]), ("boundary",), None,
                 id="boundary-no-area"),
    pytest.param(_problem(boundary=RECTANGLE[:3]), ("boundary",), "too_short",
                 id="boundary-too-few-vertices"),
    pytest.param(_problem(obstacles=[{"x": 9, "y": 1, "width": 2, "depth": 1}]),
                 ("obstacles", 0), "obstacle_outside", id="obstacle-outside"),
    pytest.param(_problem(boundary=L_SHAPE, obstacles=[{"x": 1, "y": 6.5, "width": 1, "depth": 1}]),
                 ("obstacles", 0), "obstacle_outside", id="obstacle-in-notch"),
    pytest.param(_problem(obstacles=[{"x": 1, "y": 1, "width": 2, "depth": 2},
                                     {"x": 2, "y": 2, "width": 2, "depth": 2}]),
                 ("obstacles", 1), "obstacle_overlap", id="obstacles-overlap"),
    pytest.param(_problem(rooms=[{"id": "a"}, {"id": "b"}, {"id": "a"}]), ("rooms", 2, "id"),
                 "duplicate_id", id="duplicate-room-id"),
    pytest.param(_problem(adjacency=[{"a": "nowhere", "b": "living"}]), ("adjacency", 0, "a"),
                 "unknown_room", id="adjacency-unknown-a"),
    pytest.param(_problem(adjacency=[{"a": "living", "b": "nowhere"}]), ("adjacency", 0, "b"),
                 "unknown_room", id="adjacency-unknown-b"),
    pytest.param(_problem(adjacency=[{"a": "living", "any_of": ["kitchen", "nowhere"]}]),
                 ("adjacency", 0, "any_of", 1), "unknown_room", id="adjacency-unknown-any-of"),
    pytest.param(_problem(adjacency=[{"a": "living", "b": "kitchen", "any_of": ["kitchen"]}]),
                 ("adjacency", 0), "adjacency_partner", id="adjacency-b-and-any-of"),
    pytest.param(_problem(adjacency=[{"a": "living"}]), ("adjacency", 0), "adjacency_partner",
                 id="adjacency-no-partner"),
    pytest.param(_problem(adjacency=[{"a": "living", "any_of": []}]),
                 ("adjacency", 0, "any_of"), "too_short", id="adjacency-empty-any-of"),
    pytest.param(_problem(rooms=_rooms({"id": "a", "min_size": [3, 5], "max_size": [4, 4]})),
                 ("rooms", 0, "min_size", 1), "min_above_max", id="min-size-above-max-size"),
    pytest.param(_problem(rooms=_rooms({"id": "a", "aspect_ratio": [0.5, 2]})),
                 ("rooms", 0, "aspect_ratio", 0), "ratio_below_one", id="aspect-ratio-below-one"),
    pytest.param(_problem(rooms=_rooms({"id": "a", "aspect_ratio": [3, 2]})),
                 ("rooms", 0, "aspect_ratio", 0), "ratio_order", id="aspect-ratio-lo-above-hi"),
    pytest.param(_problem(rooms=_rooms({"id": "a", "positions": [[5, 5], [11, 1]]})),
                 ("rooms", 0, "positions", 1), "point_outside", id="position-outside"),
    pytest.param(_problem(boundary=L_SHAPE, rooms=_rooms({"id": "a", "positions": [[2, 7]]})),
                 ("rooms", 0, "positions", 0), "point_outside", id="position-in-notch"),
    pytest.param(_problem(obstacles=[{"x": 1, "y": 1, "width": 2, "depth": 2}],
                          rooms=_rooms({"id": "a", "positions": [[2, 2]]})),
                 ("rooms", 0, "positions", 0), "point_in_obstacle", id="position-in-obstacle"),
    pytest.param(_problem(rooms=_rooms({"id": "a", "positions": [[1, 1], [2, 2], [3, 3]]})),
                 ("rooms", 0, "positions"), "too_long", id="three-positions"),
    pytest.param(_problem(entrance=[5, 3]), ("entrance",), "entrance_off_boundary",
                 id="entrance-inside"),
    pytest.param(_problem(entrance=[5, -1]), ("entrance",), "entrance_off_boundary",
                 id="entrance-outside"),
    pytest.param(_problem(rooms=_rooms({"id": "a", "boundary": [4]})),
                 ("rooms", 0, "boundary", 0), "unknown_edge", id="boundary-edge-index-too-big"),
    pytest.param(_problem(colour="red"), ("colour",), "extra_forbidden", id="extra-field"),
    pytest.param(_problem(rooms=_rooms({"id": "a", "colour": "red"})), ("rooms", 0, "colour"),
                 "extra_forbidden", id="extra-room-field"),
    pytest.param(_problem(obstacles=[{"x": 1, "y": 1, "width": 1, "depth": 1, "z": 0}]),
                 ("obstacles", 0, "z"), "extra_forbidden", id="extra-obstacle-field"),
    pytest.param(_problem(options={"time_limit": 5, "threads": 4}), ("options", "threads"),
                 "extra_forbidden", id="extra-option"),
    pytest.param(_problem(rooms=_rooms({"id": ""})), ("rooms", 0, "id"), "string_too_short",
                 id="empty-room-id"),
]


@pytest.mark.parametrize(("data", "loc", "kind"), INVALID)
def test_invalid_input_is_refused_naming_the_field(data: dict[str, Any], loc: Loc,
                                                   kind: str | None) -> None:
    _assert_refused(data, loc, kind)


def test_bow_tie_really_is_not_simple() -> None:
    # Guard the fixture itself: every edge is axis-aligned, yet shapely calls it invalid.
    edges = zip(BOW_TIE, BOW_TIE[1:] + BOW_TIE[:1], strict=True)
    assert all(a[0] == b[0] or a[1] == b[1] for a, b in edges)
    assert not Polygon(BOW_TIE).is_valid
    assert not Polygon(FIGURE_EIGHT).is_valid


@pytest.mark.parametrize("field", ["min_size", "max_size", "target_size"])
@pytest.mark.parametrize(("value", "kind"), [
    (math.nan, "finite_number"),
    (math.inf, "finite_number"),
    (-math.inf, "finite_number"),
    (-1.0, "greater_than_equal"),
])
def test_non_finite_and_negative_sizes_are_refused(field: str, value: float, kind: str) -> None:
    data = _problem(rooms=_rooms({"id": "a", field: [2.0, value]}))
    _assert_refused(data, ("rooms", 0, field, 1), kind)


@pytest.mark.parametrize(("loc", "data"), [
    (("boundary", 1, 0), _problem(boundary=[[0, 0], [math.nan, 0], [10, 8], [0, 8]])),
    (("entrance", 0), _problem(entrance=[math.inf, 0])),
    (("rooms", 0, "positions", 0, 1), _problem(rooms=_rooms({"id": "a",
                                                             "positions": [[1, math.nan]]}))),
    (("obstacles", 0, "width"), _problem(obstacles=[{"x": 1, "y": 1, "width": -2, "depth": 1}])),
    (("obstacles", 0, "depth"), _problem(obstacles=[{"x": 1, "y": 1, "width": 2, "depth": 0}])),
    (("rooms", 0, "aspect_ratio", 1), _problem(rooms=_rooms({"id": "a",
                                                            "aspect_ratio": [1, math.nan]}))),
    (("adjacency", 0, "min_contact"),
     _problem(adjacency=[{"a": "living", "b": "kitchen", "min_contact": -0.5}])),
    (("weights", "cover"), _problem(weights={"cover": math.nan})),
    (("options", "time_limit"), _problem(options={"time_limit": math.inf})),
])
def test_non_finite_and_negative_numbers_elsewhere_are_refused(loc: Loc,
                                                               data: dict[str, Any]) -> None:
    _assert_refused(data, loc)


def test_nan_in_json_is_refused_too() -> None:
    # JSON has no NaN, but pydantic's parser accepts the literal; the field still refuses it.
    text = json.dumps(_problem(rooms=_rooms({"id": "a", "min_size": [math.nan, 1]})))
    assert "NaN" in text
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate_json(text)
    assert [tuple(e["loc"]) for e in caught.value.errors()] == [("rooms", 0, "min_size", 0)]


def test_more_rooms_than_the_default_limit_are_refused() -> None:
    rooms = [{"id": f"r{i}"} for i in range(DEFAULT_MAX_ROOMS + 1)]
    assert DEFAULT_MAX_ROOMS == 400
    _assert_refused(_problem(rooms=rooms), ("rooms",), "too_many_rooms")
    assert len(Problem.model_validate(_problem(rooms=rooms[:-1])).rooms) == DEFAULT_MAX_ROOMS


def test_the_room_limit_comes_from_the_context() -> None:
    rooms = [{"id": f"r{i}"} for i in range(4)]
    _assert_refused(_problem(rooms=rooms), ("rooms",), "too_many_rooms",
                    context={"max_rooms": 3})
    assert Problem.model_validate(_problem(rooms=rooms[:3]), context={"max_rooms": 3})


def test_every_error_is_reported_at_once() -> None:
    # A user fixing a request wants all its faults, not one per round trip.
    data = _problem(
        rooms=[{"id": "a", "positions": [[20, 20]]}, {"id": "a"}],
        adjacency=[{"a": "a", "b": "ghost"}],
    )
    locs = {tuple(e["loc"]) for e in _refusal(data)}
    assert {("rooms", 0, "positions", 0), ("rooms", 1, "id"), ("adjacency", 0, "b")} <= locs


def test_an_unknown_compass_word_is_refused() -> None:
    errors = _refusal(_problem(rooms=_rooms({"id": "a", "boundary": ["up"]})))
    # The union of int and compass word reports one error per branch, all under the item.
    assert errors and all(tuple(e["loc"][:4]) == ("rooms", 0, "boundary", 0) for e in errors)


@pytest.mark.parametrize("north", [360, -30, 1e400, "north", True, None])
def test_north_outside_a_turn_is_refused_saying_what_to_write(north: Any) -> None:
    errors = _refusal(_problem(north=north))
    assert [(tuple(e["loc"]), e["type"]) for e in errors] == [(("north",), "north_bearing")]
    assert "0 to less than 360" in errors[0]["msg"] and "330" in errors[0]["msg"]


def test_north_is_zero_unless_given_and_any_bearing_of_a_turn_is_kept() -> None:
    assert Problem.model_validate(_problem()).north == 0.0
    assert Problem.model_validate(_problem(north=0)).north == 0.0
    assert Problem.model_validate(_problem(north=359.5)).north == 359.5


@pytest.mark.parametrize("adjacency", [
    {"a": "living", "b": "living"},
    {"a": "living", "any_of": ["living"]},
], ids=["b", "any_of"])
def test_a_room_adjacent_to_itself_is_left_to_the_infeasibility_check(
    adjacency: dict[str, Any],
) -> None:
    # A cheap impossibility (solver/verify/precheck.py, exit 3), not malformed input: the
    # request is well formed, it just cannot be met.
    Problem.model_validate(_problem(adjacency=[adjacency]))


@pytest.mark.parametrize("value", [1e9, -1e9])
def test_coordinates_and_sizes_beyond_a_hundred_kilometres_are_refused(value: float) -> None:
    far_outline = _problem(boundary=[[0, 0], [value, 0], [10, 8], [0, 8]])
    assert ("boundary", 1, 0) in {tuple(e["loc"]) for e in _refusal(far_outline)}
    huge_room = _problem(rooms=_rooms({"id": "a", "max_size": [value, 1]}))
    assert ("rooms", 0, "max_size", 0) in {tuple(e["loc"]) for e in _refusal(huge_room)}


def test_a_boolean_is_not_an_edge_index() -> None:
    errors = _refusal(_problem(rooms=_rooms({"id": "a", "boundary": [True]})))
    assert all(tuple(e["loc"][:4]) == ("rooms", 0, "boundary", 0) for e in errors)


def test_a_json_body_with_wrong_types_names_the_field() -> None:
    body = json.dumps(_problem(rooms=_rooms({"id": "a", "min_size": "big"})))
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate_json(body)
    assert tuple(caught.value.errors()[0]["loc"][:3]) == ("rooms", 0, "min_size")


def test_a_flat_outline_is_called_flat() -> None:
    errors = _refusal(_problem(boundary=[[0, 0], [4, 0], [8, 0], [4, 0]]))
    assert any("no area" in e["msg"] or "zero length" in e["msg"] for e in errors)


# Accepted input.


@pytest.mark.parametrize("path", sorted(CASES.glob("*.json")),
                         ids=lambda p: p.stem)
def test_benchmark_cases_validate(path: Path) -> None:
    problem = Problem.model_validate_json(path.read_text())
    assert problem.rooms


def test_a_closed_ring_is_accepted_as_the_open_one() -> None:
    closed = Problem.model_validate(_problem(boundary=[*RECTANGLE, RECTANGLE[0]]))
    opened = Problem.model_validate(_problem())
    assert closed.boundary == opened.boundary
    assert len(closed.boundary) == 4


def test_a_closed_l_shape_keeps_its_edge_indices() -> None:
    problem = Problem.model_validate(_problem(
        boundary=[*L_SHAPE, L_SHAPE[0]],
        rooms=_rooms({"id": "a", "boundary": [5]}),  # the last edge exists only once closed
    ))
    assert len(problem.boundary) == 6


@pytest.mark.parametrize("boundary", [
    RECTANGLE,
    list(reversed(RECTANGLE)),
    L_SHAPE,
    [[0, 0], [5, 0], [10, 0], [10, 8], [0, 8]],
], ids=["ccw", "cw", "l-shape", "collinear-vertex"])
def test_valid_outlines_are_accepted(boundary: list[list[float]]) -> None:
    assert Problem.model_validate(_problem(boundary=boundary)).outline().area > 0


def test_compass_words_and_edge_indices_are_accepted() -> None:
    data = _problem(rooms=_rooms(
        {"id": "a", "boundary": ["north", "south", "east", "west"]},
        {"id": "b", "boundary": [0, 3, "east"]},
    ))
    problem = Problem.model_validate(data)
    assert problem.room("a").boundary == ["north", "south", "east", "west"]
    assert problem.room("b").boundary == [0, 3, "east"]


def test_the_full_example_of_the_design_notes_is_accepted() -> None:
    data = {
        "name": "apartment-5",
        "boundary": [[0, 0], [12, 0], [12, 10], [0, 10]],
        "obstacles": [{"x": 5, "y": 4, "width": 2, "depth": 2, "label": "shaft"}],
        "entrance": [6.0, 0.0],
        "rooms": [
            {"id": "living", "type": "living", "min_size": [3.0, 3.0], "max_size": [7.0, 6.0],
             "target_size": [5.0, 4.5], "aspect_ratio": [1.0, 2.0], "positions": [[6.0, 0.2]],
             "boundary": ["south"]},
            {"id": "kitchen", "type": "kitchen", "target_size": [3.0, 2.5], "boundary": [1, 2]},
            {"id": "bath"}, {"id": "bed1"}, {"id": "hall"},
        ],
        "adjacency": [
            {"a": "living", "b": "kitchen", "min_contact": 0.9},
            {"a": "bath", "any_of": ["bed1", "hall"]},
        ],
        "weights": {"cover": 1.0, "size": 1.0},
        "options": {"time_limit": 30, "seed": 0, "max_levels": 3},
    }
    problem = Problem.model_validate(data)
    assert problem.adjacency[1].partners == ["bed1", "hall"]


def test_points_on_edges_are_accepted() -> None:
    # On the outline or on an obstacle's edge is still "inside": rooms may touch both.
    data = _problem(
        obstacles=[{"x": 1, "y": 1, "width": 2, "depth": 2},
                   {"x": 3, "y": 1, "width": 1, "depth": 1}],  # touching, not overlapping
        entrance=[10, 4],
        rooms=_rooms({"id": "a", "positions": [[0, 0], [1, 2]]}),
    )
    assert Problem.model_validate(data).entrance == (10, 4)
