"""Bad input is refused before solving, with an error that names the field."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError

from models import Problem

CASES = Path(__file__).resolve().parents[2] / "shared" / "bench" / "cases"
SQUARE = [[0, 0], [10, 0], [10, 8], [0, 8]]


def base(**changes: Any) -> dict[str, Any]:
    data: dict[str, Any] = {
        "boundary": SQUARE,
        "obstacles": [{"x": 4, "y": 3, "width": 2, "depth": 2}],
        "entrance": [5, 0],
        "rooms": [{"id": "a", "min_size": [2, 2], "max_size": [5, 5]}, {"id": "b"}],
        "adjacency": [{"a": "a", "b": "b"}],
    }
    data.update(changes)
    return data


def errors_of(data: dict[str, Any], **context: Any) -> list[dict[str, Any]]:
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate(data, context=context or None)
    return caught.value.errors()


def locs(data: dict[str, Any], **context: Any) -> list[tuple[Any, ...]]:
    return [tuple(e["loc"]) for e in errors_of(data, **context)]


def test_a_well_formed_problem_is_accepted() -> None:
    problem = Problem.model_validate(base())
    assert [r.id for r in problem.rooms] == ["a", "b"]


@pytest.mark.parametrize("path", sorted(CASES.glob("*.json")) if CASES.exists() else [],
                         ids=lambda p: p.stem)
def test_every_bench_case_validates(path: Path) -> None:
    Problem.model_validate_json(path.read_text())


@pytest.mark.parametrize(
    ("changes", "loc"),
    [
        ({"boundary": [[0, 0], [10, 0], [10, 8], [1, 7]]}, ("boundary", 2)),
        # Two axis-aligned edges cross: a bow tie.
        ({"boundary": [[0, 0], [4, 0], [4, 4], [2, 4], [2, -2], [0, -2]]}, ("boundary",)),
        ({"boundary": [[0, 0], [10, 0], [10, 0], [10, 8], [0, 8]]}, ("boundary", 1)),
        ({"obstacles": [{"x": 9, "y": 3, "width": 2, "depth": 2}]}, ("obstacles", 0)),
        ({"obstacles": [{"x": 1, "y": 1, "width": 2, "depth": 2},
                        {"x": 2, "y": 2, "width": 2, "depth": 2}]}, ("obstacles", 1)),
        ({"rooms": [{"id": "a"}, {"id": "a"}], "adjacency": []}, ("rooms", 1, "id")),
        ({"adjacency": [{"a": "a", "b": "ghost"}]}, ("adjacency", 0, "b")),
        ({"adjacency": [{"a": "ghost", "b": "a"}]}, ("adjacency", 0, "a")),
        ({"adjacency": [{"a": "a", "any_of": ["b", "ghost"]}]}, ("adjacency", 0, "any_of", 1)),
        ({"rooms": [{"id": "a", "min_size": [3, 2], "max_size": [2, 5]}], "adjacency": []},
         ("rooms", 0, "min_size", 0)),
        ({"rooms": [{"id": "a", "aspect_ratio": [0.5, 2]}], "adjacency": []},
         ("rooms", 0, "aspect_ratio", 0)),
        ({"rooms": [{"id": "a", "aspect_ratio": [3, 2]}], "adjacency": []},
         ("rooms", 0, "aspect_ratio", 0)),
        ({"rooms": [{"id": "a", "positions": [[1, 1], [11, 1]]}], "adjacency": []},
         ("rooms", 0, "positions", 1)),
        ({"rooms": [{"id": "a", "positions": [[5, 4]]}], "adjacency": []},
         ("rooms", 0, "positions", 0)),
        ({"rooms": [{"id": "a", "boundary": [7]}], "adjacency": []}, ("rooms", 0, "boundary", 0)),
        ({"rooms": [{"id": "a", "boundary": ["up"]}], "adjacency": []},
         ("rooms", 0, "boundary", 0, "literal['north','south','east','west']")),
        ({"entrance": [5, 4]}, ("entrance",)),
        ({"adjacency": [{"a": "a", "b": "b", "any_of": ["b"]}]}, ("adjacency", 0)),
        ({"weights": {"cover": -1}}, ("weights", "cover")),
        ({"options": {"time_limit": 0}}, ("options", "time_limit")),
        ({"colour": "blue"}, ("colour",)),
    ],
    ids=[
        "not-axis-aligned", "self-intersecting", "degenerate-edge", "obstacle-outside",
        "obstacles-overlap", "duplicate-id", "unknown-b", "unknown-a", "unknown-any-of",
        "min-above-max", "ratio-below-one", "ratio-reversed", "position-outside",
        "position-in-obstacle", "unknown-edge", "unknown-compass-word", "entrance-inside",
        "b-and-any-of", "negative-weight", "zero-time-limit", "unknown-field",
    ],
)
def test_each_kind_of_bad_input_names_its_field(
    changes: dict[str, Any], loc: tuple[Any, ...]
) -> None:
    assert loc in locs(base(**changes))


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, -1.0, 1e9])
def test_non_finite_negative_and_huge_sizes_are_refused(bad: float) -> None:
    data = base(rooms=[{"id": "a", "min_size": [bad, 2]}], adjacency=[])
    assert ("rooms", 0, "min_size", 0) in locs(data)


def test_non_finite_numbers_are_refused_in_coordinates_too() -> None:
    assert ("boundary", 1, 0) in locs(base(boundary=[[0, 0], [math.nan, 0], [10, 8], [0, 8]]))


def test_errors_carry_a_readable_message() -> None:
    data = base(rooms=[{"id": "a", "min_size": [3, 2], "max_size": [2, 5]}], adjacency=[])
    (error,) = errors_of(data)
    assert "exceeds maximum" in error["msg"]


def test_more_rooms_than_the_default_limit_are_refused() -> None:
    rooms = [{"id": f"r{k}"} for k in range(401)]
    assert ("rooms",) in locs(base(rooms=rooms, adjacency=[]))


def test_the_room_limit_can_be_set_by_the_caller() -> None:
    rooms = [{"id": f"r{k}"} for k in range(4)]
    assert ("rooms",) in locs(base(rooms=rooms, adjacency=[]), max_rooms=3)
    Problem.model_validate(base(rooms=rooms, adjacency=[]), context={"max_rooms": 4})


def test_a_closed_ring_is_accepted_and_keeps_edge_numbering() -> None:
    problem = Problem.model_validate(base(boundary=[*SQUARE, SQUARE[0]]))
    assert len(problem.boundary) == 4


def test_edge_indices_and_compass_words_are_both_accepted() -> None:
    problem = Problem.model_validate(
        base(rooms=[{"id": "a", "boundary": [0, "north", "east"]}], adjacency=[])
    )
    assert problem.rooms[0].boundary == [0, "north", "east"]


def test_a_json_body_with_wrong_types_names_the_field() -> None:
    body = json.dumps(base(rooms=[{"id": "a", "min_size": "big"}], adjacency=[]))
    with pytest.raises(ValidationError) as caught:
        Problem.model_validate_json(body)
    assert caught.value.errors()[0]["loc"][:3] == ("rooms", 0, "min_size")
