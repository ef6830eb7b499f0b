"""The independent checker: each constraint family on hand-built layouts, no solver."""

from __future__ import annotations

from typing import Any

import pytest

from floorplan.models import ConstraintCheck, Problem
from floorplan.solver.geometry import Box
from floorplan.solver.verify.checker import CheckResult, check_layout

# A 10 x 6 rectangle: edge 0 south, 1 east, 2 north, 3 west.
OUTLINE = [[0, 0], [10, 0], [10, 6], [0, 6]]


def problem(*rooms: dict[str, Any], **extra: Any) -> Problem:
    """A problem on OUTLINE with the given rooms and any further fields."""
    return Problem.model_validate({"boundary": OUTLINE, "rooms": list(rooms), **extra})


def of_kind(result: CheckResult, kind: str) -> list[ConstraintCheck]:
    return [c for c in result.constraints if c.kind == kind]


def one(result: CheckResult, kind: str) -> ConstraintCheck:
    (check,) = of_kind(result, kind)
    return check


# Two rooms filling OUTLINE, sharing the wall x = 4 (6 m long).
HALVES = {"a": [Box(0, 0, 4, 6)], "b": [Box(4, 0, 10, 6)]}


def test_clean_layout_is_valid_and_fully_covered() -> None:
    result = check_layout(problem({"id": "a"}, {"id": "b"}), HALVES)
    assert result.valid
    assert result.coverage == pytest.approx(1.0)
    assert result.uncovered_area == pytest.approx(0.0)
    assert all(c.satisfied for c in result.constraints)
    assert {c.kind for c in result.constraints} == {"inside", "connected", "overlap", "coverage"}
    assert one(result, "overlap").rooms == ["a", "b"]
    assert one(result, "coverage").detail.startswith("coverage 100.0 %")


# inside (Eq. 1)


def test_inside_fails_outside_the_outline() -> None:
    result = check_layout(problem({"id": "a"}), {"a": [Box(8, 0, 11, 3)]})
    check = one(result, "inside")
    assert not check.satisfied
    assert check.detail == "3.00 m² outside the free area"
    assert not result.valid


def test_inside_fails_on_an_obstacle_and_holds_beside_it() -> None:
    p = problem({"id": "a"}, obstacles=[{"x": 4, "y": 0, "width": 2, "depth": 2}])
    assert not one(check_layout(p, {"a": [Box(3, 0, 5, 3)]}), "inside").satisfied
    assert one(check_layout(p, {"a": [Box(0, 0, 4, 3)]}), "inside").satisfied


def test_inside_tolerates_solver_noise_below_tol() -> None:
    result = check_layout(problem({"id": "a"}), {"a": [Box(-5e-5, 0, 10.00005, 6)]})
    assert one(result, "inside").satisfied


# connected


def test_l_shaped_room_is_connected_and_sized_by_its_bounding_box() -> None:
    p = problem({"id": "a", "min_size": [4, 4], "max_size": [4, 4], "target_size": [3, 3]})
    result = check_layout(p, {"a": [Box(0, 0, 4, 2), Box(0, 2, 2, 4)]})
    assert one(result, "connected").satisfied
    assert one(result, "size").satisfied
    assert result.size_error == {"a": pytest.approx(2.0)}


def test_corner_touching_rectangles_are_not_connected() -> None:
    result = check_layout(problem({"id": "a"}), {"a": [Box(0, 0, 2, 2), Box(2, 2, 4, 4)]})
    check = one(result, "connected")
    assert not check.satisfied
    assert "MultiPolygon" in check.detail
    assert not result.valid


def test_rectangles_apart_by_solver_noise_are_connected() -> None:
    result = check_layout(problem({"id": "a"}), {"a": [Box(0, 0, 2, 2), Box(2.00001, 0, 4, 2)]})
    assert one(result, "connected").satisfied


# overlap (Eq. 2)


def test_overlap_reports_each_overlapping_pair() -> None:
    p = problem({"id": "a"}, {"id": "b"}, {"id": "c"})
    result = check_layout(
        p, {"a": [Box(0, 0, 4, 6)], "b": [Box(3, 0, 6, 6)], "c": [Box(6, 0, 10, 6)]}
    )
    (check,) = of_kind(result, "overlap")
    assert not check.satisfied
    assert check.rooms == ["a", "b"]
    assert check.detail == "overlap 6.00 m²"
    assert not result.valid


def test_rooms_touching_along_a_wall_do_not_overlap() -> None:
    result = check_layout(problem({"id": "a"}, {"id": "b"}), HALVES)
    assert one(result, "overlap").satisfied


# size (Eq. 5) and size error (Eq. 6)


@pytest.mark.parametrize(
    ("bounds", "satisfied"),
    [
        ({"min_size": [3, 5], "max_size": [5, 6]}, True),
        ({"min_size": [3, 6.5]}, False),
        ({"max_size": [3.5, 6]}, False),
        # The bounds are per axis: a 4 x 6 room is not a 6 x 4 room.
        ({"min_size": [6, 4], "max_size": [6, 4]}, False),
    ],
)
def test_size_bounds(bounds: dict[str, Any], satisfied: bool) -> None:
    result = check_layout(problem({"id": "a", **bounds}, {"id": "b"}), HALVES)
    assert one(result, "size").satisfied is satisfied
    assert result.valid is satisfied


def test_size_error_is_exact_per_room_with_a_target() -> None:
    p = problem({"id": "a", "target_size": [5, 4]}, {"id": "b", "target_size": [6, 6]},
                {"id": "c"})
    result = check_layout(p, {**HALVES, "c": [Box(0, 0, 1, 1)]})
    # a is 4 x 6: (4-5)^2 + (6-4)^2 = 5; b matches exactly; c has no target.
    assert result.size_error == {"a": pytest.approx(5.0), "b": pytest.approx(0.0)}


# aspect ratio (Eq. 7)


@pytest.mark.parametrize(
    ("ratio", "satisfied"), [([1.0, 2.0], True), ([1.6, 3.0], False), ([1.0, 1.4], False)]
)
def test_aspect_ratio_in_either_orientation(ratio: list[float], satisfied: bool) -> None:
    # a is 4 wide and 6 deep: a vertical room with ratio 1.5.
    result = check_layout(problem({"id": "a", "aspect_ratio": ratio}, {"id": "b"}), HALVES)
    check = one(result, "aspect_ratio")
    assert check.satisfied is satisfied
    assert check.detail.startswith("ratio 1.50")


# position (Eq. 8)


def test_position_covered_and_missed() -> None:
    p = problem({"id": "a", "positions": [[1, 1], [4, 6]]}, {"id": "b", "positions": [[1, 1]]})
    result = check_layout(p, HALVES)
    checks = of_kind(result, "position")
    # (4, 6) lies on a's corner, which still covers it.
    assert [(c.rooms, c.satisfied) for c in checks] == [
        (["a"], True), (["a"], True), (["b"], False)
    ]
    assert checks[2].detail == "misses (1.00, 1.00) by 3.00 m"


# boundary (Eq. 9)


@pytest.mark.parametrize(
    ("edges", "satisfied"),
    [(["west"], True), ([0], True), ([1, "south"], True), (["east"], False), ([1], False)],
)
def test_boundary_edges_by_index_and_compass(edges: list[Any], satisfied: bool) -> None:
    # A room in the south-west corner, 3 x 2: touches south (0) and west (3) only.
    p = problem({"id": "a", "boundary": edges})
    result = check_layout(p, {"a": [Box(0, 0, 3, 2)]})
    assert one(result, "boundary").satisfied is satisfied


def test_boundary_corner_contact_is_not_enough() -> None:
    # An L-shaped outline; edge 2 runs from (10, 3) west to (4, 3).
    p = Problem.model_validate({
        "boundary": [[0, 0], [10, 0], [10, 3], [4, 3], [4, 6], [0, 6]],
        "rooms": [{"id": "a", "boundary": [2]}],
    })
    assert not one(check_layout(p, {"a": [Box(2, 3, 4, 6)]}), "boundary").satisfied
    assert one(check_layout(p, {"a": [Box(4, 0, 6, 3)]}), "boundary").satisfied


# adjacency (Eq. 10 / 11)


def two_rooms_sharing_two_metres() -> dict[str, list[Box]]:
    return {"a": [Box(0, 0, 3, 3)], "b": [Box(3, 1, 6, 3)]}


@pytest.mark.parametrize(("min_contact", "satisfied"), [(0.9, True), (2.0, True), (2.5, False)])
def test_adjacency_contact_length(min_contact: float, satisfied: bool) -> None:
    p = problem({"id": "a"}, {"id": "b"},
                adjacency=[{"a": "a", "b": "b", "min_contact": min_contact}])
    check = one(check_layout(p, two_rooms_sharing_two_metres()), "adjacency")
    assert check.satisfied is satisfied
    assert check.detail == f"contact 2.00 m (needs {min_contact:.2f})"


def test_adjacency_contact_is_one_straight_stretch_not_the_sum_of_walls() -> None:
    """An L wrapping its partner's corner shares 0.6 m on each of two walls: 1.2 m in
    all, but no stretch a 0.9 m door fits in, and Eq. 10 asks for one."""
    p = problem({"id": "a"}, {"id": "b"}, adjacency=[{"a": "a", "b": "b"}])
    rooms = {"a": [Box(0, 0, 3, 2.4), Box(0, 2.4, 2.4, 3)], "b": [Box(2.4, 2.4, 4, 4)]}
    check = one(check_layout(p, rooms), "adjacency")
    assert not check.satisfied
    assert check.detail == "contact 0.60 m (needs 0.90)"


def test_adjacency_tolerates_a_hairline_gap() -> None:
    p = problem({"id": "a"}, {"id": "b"}, adjacency=[{"a": "a", "b": "b"}])
    rooms = {"a": [Box(0, 0, 3, 3)], "b": [Box(3.0000004, 1, 6, 3)]}
    assert one(check_layout(p, rooms), "adjacency").satisfied


def test_adjacency_zero_contact_still_needs_touching() -> None:
    p = problem({"id": "a"}, {"id": "b"}, adjacency=[{"a": "a", "b": "b", "min_contact": 0}])
    assert one(check_layout(p, {"a": [Box(0, 0, 2, 2)], "b": [Box(2, 2, 4, 4)]}),
               "adjacency").satisfied
    assert not one(check_layout(p, {"a": [Box(0, 0, 2, 2)], "b": [Box(3, 0, 4, 2)]}),
                   "adjacency").satisfied


def test_adjacency_any_of_uses_the_best_partner() -> None:
    p = problem({"id": "a"}, {"id": "b"}, {"id": "c"},
                adjacency=[{"a": "a", "any_of": ["c", "b"]}])
    rooms = {**two_rooms_sharing_two_metres(), "c": [Box(7, 0, 9, 2)]}
    check = one(check_layout(p, rooms), "adjacency")
    assert check.satisfied
    assert check.rooms == ["a", "c", "b"]
    assert check.detail == "best contact 2.00 m with 'b' (needs 0.90)"
    rooms["b"] = [Box(5, 0, 6, 1)]
    assert not one(check_layout(p, rooms), "adjacency").satisfied


@pytest.mark.parametrize("adjacency", [{"a": "a", "b": "a"}, {"a": "a", "any_of": ["b", "a"]}])
def test_adjacency_to_itself_is_unsatisfied(adjacency: dict[str, Any]) -> None:
    p = problem({"id": "a"}, {"id": "b"}, adjacency=[adjacency])
    assert not one(check_layout(p, two_rooms_sharing_two_metres()), "adjacency").satisfied


# coverage (soft)


def test_low_coverage_is_reported_but_keeps_the_layout_valid() -> None:
    result = check_layout(problem({"id": "a"}), {"a": [Box(0, 0, 5, 6)]})
    check = one(result, "coverage")
    assert not check.satisfied
    assert check.detail == "coverage 50.0 %, 30.00 m² uncovered"
    assert result.coverage == pytest.approx(0.5)
    assert result.uncovered_area == pytest.approx(30.0)
    assert result.valid


def test_coverage_counts_only_free_area_and_overlaps_once() -> None:
    p = problem({"id": "a"}, {"id": "b"}, obstacles=[{"x": 8, "y": 0, "width": 2, "depth": 6}])
    result = check_layout(p, {"a": [Box(0, 0, 5, 6)], "b": [Box(4, 0, 8, 6)]})
    assert result.coverage == pytest.approx(1.0)
    assert one(result, "coverage").satisfied
    assert not result.valid  # a and b overlap


# placed


def test_missing_room_fails_placed_and_its_own_constraints() -> None:
    p = problem({"id": "a", "min_size": [1, 1], "positions": [[1, 1]], "target_size": [2, 2]},
                {"id": "b"}, adjacency=[{"a": "b", "b": "a"}])
    result = check_layout(p, {"b": [Box(0, 0, 10, 6)]})
    assert not one(result, "placed").satisfied
    assert one(result, "placed").rooms == ["a"]
    for kind in ("size", "position", "adjacency"):
        assert not one(result, kind).satisfied
    assert result.size_error == {}
    assert not result.valid


def test_unknown_room_id_fails_placed() -> None:
    rooms = {"a": [Box(0, 0, 10, 6)], "ghost": [Box(0, 0, 1, 1)]}
    result = check_layout(problem({"id": "a"}), rooms)
    check = one(result, "placed")
    assert (check.rooms, check.satisfied) == (["ghost"], False)
