"""A batch's layout moved apart from the plans it repeats (solver.pipeline.spread):
whole wall lines moved until the nearest held plan differs by more than 5 % of the
floor, the layout kept valid and covering as much."""

from __future__ import annotations

import random
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from floorplan.models import Problem
from floorplan.solver import solve
from floorplan.solver.distinct import SAME_PLAN_SHARE, floor_grid, raster
from floorplan.solver.geometry import Box
from floorplan.solver.pipeline.spread import (
    _line_moves,
    _toward_other_sizes,
    spread_apart,
    spread_layout,
)
from floorplan.solver.verify.checker import check_layout


def two_rooms(width_bounds: tuple[float, float]) -> Problem:
    """A 10 x 8 floor for two rooms side by side, each as wide as `width_bounds`."""
    lo, hi = width_bounds
    data: dict[str, Any] = {
        "boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
        "rooms": [{"id": room, "min_size": [lo, 8], "max_size": [hi, 8],
                   "target_size": [5, 8]} for room in ("left", "right")],
    }
    return Problem.model_validate(data)


def grid(rooms: dict[str, list[Box]]) -> np.ndarray:
    number = {room_id: k + 1 for k, room_id in enumerate(sorted(rooms))}
    return floor_grid([(number[i], b.x0, b.y0, b.x1, b.y1)
                       for i, rects in rooms.items() for b in rects])


def spread(problem: Problem, rooms: dict[str, list[Box]], others: list[np.ndarray]
           ) -> dict[str, list[Box]] | None:
    moved = spread_apart(problem, rooms, check_layout(problem, rooms), np.stack(others),
                         until=time.monotonic() + 1, rng=random.Random(0))
    return None if moved is None else moved[0]


HALVES = {"left": [Box(0, 0, 5, 8)], "right": [Box(5, 0, 10, 8)]}


def test_the_wall_moves_until_the_plan_differs_from_the_one_held() -> None:
    brief = two_rooms((3, 7))
    moved = spread(brief, HALVES, [grid(HALVES)])
    assert moved is not None
    check = check_layout(brief, moved)
    assert check.valid and check.coverage == pytest.approx(1.0)
    differing = (grid(moved) != grid(HALVES)).mean()
    assert differing > SAME_PLAN_SHARE
    # The outline's walls stay where they are.
    assert moved["left"][0].x0 == 0 and moved["right"][0].x1 == 10


def test_bounds_that_leave_no_room_to_move_give_no_layout() -> None:
    # Each room 4.8-5.2 m wide: the wall moves 0.2 m at most, 2 % of the floor.
    assert spread(two_rooms((4.8, 5.2)), HALVES, [grid(HALVES)]) is None


def test_a_plan_moved_away_from_one_does_not_land_on_another() -> None:
    brief = two_rooms((3, 7))
    # Held: the wall at 5 (this plan) and at 3; the move must go right, past 5.5.
    at_three = {"left": [Box(0, 0, 3, 8)], "right": [Box(3, 0, 10, 8)]}
    moved = spread(brief, HALVES, [grid(HALVES), grid(at_three)])
    assert moved is not None and moved["left"][0].x1 > 5.5


def test_a_strip_between_two_rooms_moves_with_the_wall() -> None:
    # A 0.1 m strip of bare floor between the rooms: both of its walls move together,
    # so no move widens it (coverage never falls) or closes it by chance.
    rooms = {"left": [Box(0, 0, 4.95, 8)], "right": [Box(5.05, 0, 10, 8)]}
    for moved in _line_moves(rooms, ([0, 10], [0, 8])):
        left, right = moved["left"][0], moved["right"][0]
        assert right.x0 - left.x1 == pytest.approx(0.1)


@pytest.mark.slow
def test_rooms_reshaped_toward_other_sizes_stay_valid_and_covering() -> None:
    # What wall lines alone cannot move apart: floor traded between neighbours toward
    # sizes drawn under another seed.
    brief = Problem.model_validate_json(Path("examples/apartment-5.json").read_text())
    layout = solve(brief.with_options(time_limit=5, seed=3))
    rooms = {r.id: [Box.of(b) for b in r.rectangles] for r in layout.rooms}
    check = check_layout(brief, rooms)
    found = _toward_other_sizes(brief, rooms, check, 0, time.monotonic() + 1)
    assert found is not None
    reshaped, again = found
    assert again.valid and again.coverage >= check.coverage - 1e-9
    assert grid(reshaped).tolist() != grid(rooms).tolist()


@pytest.mark.slow
def test_a_solved_layout_is_moved_apart_and_keeps_its_doors_and_report() -> None:
    brief = Problem.model_validate_json(Path("examples/apartment-5.json").read_text())
    layout = solve(brief.with_options(time_limit=5, seed=3))
    assert layout.report.valid
    _, held = raster(layout)
    moved = spread_layout(brief, layout, held[None, :], seconds=1.0, seed=0)
    assert moved is not None
    assert moved.report.valid and moved.report.coverage >= layout.report.coverage - 1e-9
    assert moved.report.termination == layout.report.termination
    assert moved.doors and {r.id for r in moved.rooms} == {r.id for r in layout.rooms}
    _, grid_moved = raster(moved)
    assert (grid_moved != held).mean() > SAME_PLAN_SHARE
    assert check_layout(brief, {r.id: [Box.of(b) for b in r.rectangles]
                                for r in moved.rooms}).valid
