"""The slicing start: rows of rooms that fill the free floor, sized by a convex QP."""

from __future__ import annotations

import time
from typing import Any

import pytest

from floorplan.models import Adjacency, Problem, Termination
from floorplan.solver import solve
from floorplan.solver.geometry import make_domain
from floorplan.solver.heuristics.slicing import (
    DEMANDS_UP_TO,
    DOOR_TREE_UP_TO,
    slicing_applies,
    slicing_layout,
)
from floorplan.solver.verify.checker import check_layout


def offices(count: int, **fields: Any) -> Problem:
    # 24 x 12 m with a 4 x 4 m core; the targets add up to the free area, half of the
    # rooms a little wide and half a little deep.
    free = 24 * 12 - 16
    side = (free / count) ** 0.5
    data: dict[str, Any] = {
        "boundary": [[0, 0], [24, 0], [24, 12], [0, 12]],
        "obstacles": [{"x": 10, "y": 4, "width": 4, "depth": 4, "label": "core"}],
        "rooms": [{"id": f"o{i}", "type": "office", "min_size": [2, 2], "max_size": [8, 8],
                   "target_size": [side * stretch, side / stretch]}
                  for i, stretch in zip(range(count), [1.2, 0.85] * count, strict=False)],
    }
    data.update(fields)
    return Problem.model_validate(data)


def tiled_offices() -> Problem:
    # Targets read off a tiling that exists: rows of 4 m deep rooms, 4 m wide along the
    # full-width bands and 5 m wide beside the core. Zero E_size is possible.
    sizes = [(4.0, 4.0)] * 12 + [(5.0, 4.0)] * 4
    return offices(16).model_copy(update={"rooms": [
        room.model_copy(update={"target_size": size})
        for room, size in zip(offices(16).rooms, sizes, strict=True)]})


def test_rows_fill_the_floor_and_honour_sizes_and_guide_points() -> None:
    p = tiled_offices()
    rooms = p.rooms
    rooms[0] = rooms[0].model_copy(update={"positions": [(22.5, 11.0)]})
    rooms[1] = rooms[1].model_copy(update={"positions": [(1.0, 1.0)]})
    p = p.model_copy(update={"rooms": rooms})
    rects = slicing_layout(p, make_domain(p), deadline=time.monotonic() + 5)
    assert rects is not None and set(rects) == {r.id for r in p.rooms}
    check = check_layout(p, {k: [b] for k, b in rects.items()})
    assert check.valid, [c for c in check.constraints if not c.satisfied]
    assert check.coverage > 0.999
    assert rects["o0"].contains_point(22.5, 11.0) and rects["o1"].contains_point(1.0, 1.0)
    # Sized to the targets: close to the tiling they were read off (the dealing's
    # hill-climb ends in a near tiling here, 0.13 m² a room, not always the exact one).
    assert sum(check.size_error.values()) / len(p.rooms) < 0.2


def _strip_rooms(count: int, **first: Any) -> list[dict[str, Any]]:
    return [{"id": f"s{i}", "type": "shop", "min_size": [2, 2], "max_size": [8, 8],
             "target_size": [3, 3], **(first if i == 0 else {})} for i in range(count)]


def test_a_guide_point_beside_a_notch_gets_a_region_that_reaches_it() -> None:
    # The point lies in the 1 m strip above the 20 x 3 m bar, too shallow to be a row
    # of its own: the rows are cut from the 6 x 4 m rectangle around it and the rest.
    p = Problem.model_validate({
        "boundary": [[0, 0], [20, 0], [20, 3], [6, 3], [6, 4], [0, 4]],
        "rooms": _strip_rooms(7, positions=[[1.0, 3.6]])})
    rects = slicing_layout(p, make_domain(p), deadline=time.monotonic() + 5)
    assert rects is not None
    assert rects["s0"].contains_point(1.0, 3.6)
    check = check_layout(p, {k: [b] for k, b in rects.items()})
    assert check.valid, [c for c in check.constraints if not c.satisfied]
    assert check.coverage > 0.999


def test_a_loose_room_is_not_dealt_between_guide_points_it_cannot_fit_between() -> None:
    # Even spreading would put s2 (at least 2 m wide) between the points of s0 and s1,
    # 1 m apart, where no row order can hold it.
    rooms = _strip_rooms(4)
    rooms[0]["positions"], rooms[1]["positions"] = [[2.5, 1.5]], [[3.5, 1.5]]
    p = Problem.model_validate({"boundary": [[0, 0], [12, 0], [12, 3], [0, 3]],
                                "rooms": rooms})
    rects = slicing_layout(p, make_domain(p), deadline=time.monotonic() + 5)
    assert rects is not None
    assert rects["s0"].contains_point(2.5, 1.5) and rects["s1"].contains_point(3.5, 1.5)
    assert check_layout(p, {k: [b] for k, b in rects.items()}).valid


def test_no_row_plan_when_the_bounds_cannot_fill_the_floor() -> None:
    # Three rooms of at most 3 x 3 m cannot fill 288 m² edge to edge.
    p = offices(3)
    p = p.model_copy(update={"rooms": [r.model_copy(update={"max_size": (3.0, 3.0),
                                                           "min_size": (2.0, 2.0),
                                                           "target_size": (3.0, 3.0)})
                                       for r in p.rooms]})
    assert slicing_layout(p, make_domain(p), deadline=time.monotonic() + 5) is None


def test_demands_are_sliced_up_to_a_size_and_sizes_alone_at_any_size() -> None:
    assert slicing_applies(offices(6))
    assert slicing_applies(offices(6, adjacency=[{"a": "o0", "b": "o1"}]))
    many = offices(DEMANDS_UP_TO + 2)
    assert slicing_applies(many)
    assert not slicing_applies(many.model_copy(update={"adjacency": [
        Adjacency(a="o0", b="o1")]}))


def test_a_tree_of_doors_is_sliced_only_on_small_floors() -> None:
    def door_tree(rooms: int) -> Problem:
        return offices(rooms).model_copy(update={"adjacency": [
            Adjacency(a=f"o{k}", b=f"o{k + 1}") for k in range(rooms - 1)]})

    assert slicing_applies(door_tree(DOOR_TREE_UP_TO))
    assert not slicing_applies(door_tree(DOOR_TREE_UP_TO + 1))
    # A few doors among many rooms still slice (offices along a corridor).
    assert slicing_applies(offices(24).model_copy(update={"adjacency": [
        Adjacency(a="o0", b="o1"), Adjacency(a="o2", b="o3")]}))


def flat(**fields: Any) -> Problem:
    # A 10 x 8 m flat: living and bedroom on the north facade, kitchen on the east,
    # foyer reached from the entrance on the south side, the bathroom off the bedroom.
    data: dict[str, Any] = {
        "boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
        "entrance": [5.0, 0.0],
        "rooms": [
            {"id": "foyer", "type": "foyer", "min_size": [1.4, 1.4], "max_size": [3.5, 3.5],
             "target_size": [2.0, 2.5], "positions": [[5.0, 0.3]]},
            {"id": "living", "type": "living", "min_size": [3.2, 3.2],
             "max_size": [7, 7], "target_size": [5.0, 4.5], "boundary": ["north"]},
            {"id": "kitchen", "type": "kitchen", "min_size": [2.1, 2.1],
             "max_size": [4.2, 4.2], "target_size": [3.0, 3.0], "boundary": ["east"]},
            {"id": "bedroom", "type": "bedroom", "min_size": [2.7, 2.7],
             "max_size": [5.6, 5.6], "target_size": [4.0, 3.8], "boundary": ["north"]},
            {"id": "bath", "type": "bathroom", "min_size": [1.5, 1.5],
             "max_size": [3.5, 3.5], "target_size": [2.5, 2.2]},
        ],
        "adjacency": [
            {"a": "foyer", "b": "living"}, {"a": "living", "b": "kitchen"},
            {"a": "living", "b": "bedroom", "min_contact": 1.2},
            {"a": "bath", "any_of": ["bedroom", "foyer"]},
        ],
    }
    data.update(fields)
    return Problem.model_validate(data)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rows_honour_adjacency_boundary_and_guide_points(seed: int) -> None:
    p = flat()
    rects = slicing_layout(p, make_domain(p), deadline=time.monotonic() + 5, seed=seed)
    assert rects is not None
    # The independent checker, on contact lengths, facades and the guide point.
    check = check_layout(p, {k: [b] for k, b in rects.items()})
    assert check.valid, [c for c in check.constraints if not c.satisfied]
    assert check.coverage > 0.999
    kinds = {c.kind for c in check.constraints}
    assert {"adjacency", "boundary", "position"} <= kinds


def test_no_row_plan_when_rows_cannot_hold_the_demands() -> None:
    # The foyer (at most 2 m deep) and the living room (at least 3.2 m) must both lie on
    # the south facade and share a wall: in rows they would share a row, hence a depth.
    rooms = [r.model_copy(update={"boundary": ["south"]}) if r.id == "living" else r
             for r in flat().rooms]
    rooms = [r.model_copy(update={"max_size": (2.0, 2.0), "target_size": (1.8, 1.8)})
             if r.id == "foyer" else r for r in rooms]
    p = flat().model_copy(update={"rooms": rooms})
    # No plan holds them, so the search runs to its deadline and gives up (how soon it
    # stops is the bench's to time).
    assert slicing_layout(p, make_domain(p), deadline=time.monotonic() + 0.5) is None


@pytest.mark.slow
def test_a_size_only_problem_solves_fully_covered_and_ends_when_the_search_stalls() -> None:
    # 16 rooms stall in about 15 s (30 took twice that, proving nothing more); the limit
    # is far above that, so a busy machine still stalls first. Stalled or optimal: ended
    # by the search itself, before its time limit.
    p = offices(16, options={"time_limit": 120})
    layout = solve(p)
    assert layout.report.valid and layout.report.coverage > 0.999
    assert layout.report.termination in (Termination.STALLED, Termination.OPTIMAL)
