"""Sliding whole walls (docs/method.md, "The steps", step 6): a wall several rooms
share, or a rectangle between two others, moves where the rooms' targets ask, and no
room overlaps another, loses floor to a gap or breaks a constraint for it."""

from __future__ import annotations

import time
from typing import Any

from floorplan.models import Problem
from floorplan.solver.geometry import Box, make_domain
from floorplan.solver.heuristics.wall_slide import slide_walls
from floorplan.solver.verify.checker import check_layout

Rooms = dict[str, list[Box]]


def brief(rooms: list[dict[str, Any]], **fields: Any) -> Problem:
    return Problem.model_validate({"boundary": [[0, 0], [9, 0], [9, 6], [0, 6]],
                                   "rooms": rooms, **fields})


def slid(problem: Problem, rooms: Rooms) -> tuple[Rooms, int]:
    return slide_walls(problem, make_domain(problem), rooms,
                       deadline=time.monotonic() + 5.0)


def test_a_wall_three_rooms_share_moves_for_all_of_them() -> None:
    # A corridor 2 m deep along the south, three bedrooms 3 x 4 above it whose targets
    # are 3 x 4.5: the corridor's one wall moves down 0.5 m for all three at once (a
    # strip between two rooms would give one bedroom an L and leave the others short).
    p = brief([{"id": "corridor", "target_size": [9, 1.5]},
               *({"id": f"bed{k}", "target_size": [3, 4.5]} for k in range(3))])
    start = {"corridor": [Box(0, 0, 9, 2)],
             **{f"bed{k}": [Box(3 * k, 2, 3 * k + 3, 6)] for k in range(3)}}
    after, moves = slid(p, start)
    assert moves >= 1
    assert after["corridor"] == [Box(0, 0, 9, 1.5)]
    assert all(after[f"bed{k}"] == [Box(3 * k, 1.5, 3 * k + 3, 6)] for k in range(3))
    check = check_layout(p, after)
    assert check.valid and check.coverage == 1.0


def test_a_room_slides_between_its_neighbours() -> None:
    # a | b | c in a row: a is 1 m too narrow, c 1 m too wide, b at its target. Moving
    # either wall alone shrinks b, whose small target makes that the dearer error; b
    # slides east whole instead.
    p = brief([{"id": "a", "target_size": [4, 6]}, {"id": "b", "target_size": [1.5, 6]},
               {"id": "c", "target_size": [3.5, 6]}])
    start = {"a": [Box(0, 0, 3, 6)], "b": [Box(3, 0, 4.5, 6)], "c": [Box(4.5, 0, 9, 6)]}
    after, _ = slid(p, start)
    assert after == {"a": [Box(0, 0, 4, 6)], "b": [Box(4, 0, 5.5, 6)],
                     "c": [Box(5.5, 0, 9, 6)]}


def test_a_room_grows_across_a_gap_while_the_floor_is_short_of_its_coverage() -> None:
    # A gap 1 m wide along the east wall (11 % of the floor): the bedroom, at its
    # target, grows over it, which Eq. 12's lambda_cover of 1 alone would not buy.
    p = brief([{"id": "living", "target_size": [5, 6]}, {"id": "bed", "target_size": [3, 6]}])
    start = {"living": [Box(0, 0, 5, 6)], "bed": [Box(5, 0, 8, 6)]}
    assert check_layout(p, start).coverage < 0.9
    after, _ = slid(p, start)
    check = check_layout(p, after)
    assert check.valid and check.coverage == 1.0


def test_a_gap_within_the_coverage_goal_is_traded_as_eq_12_prices_it() -> None:
    # 8 cm along the east wall (0.9 % of the floor), both rooms at their targets. At
    # lambda_cover 1 the wc slides over it and the living room takes the strip it
    # leaves (0.11 of area error for 0.48 m² covered); at 0.1 the gap stays.
    rooms = [{"id": "living", "target_size": [7.5, 6]},
             {"id": "wc", "target_size": [1.42, 6]}]
    start = {"living": [Box(0, 0, 7.5, 6)], "wc": [Box(7.5, 0, 8.92, 6)]}
    after, _ = slid(brief(rooms), start)
    assert after == {"living": [Box(0, 0, 7.58, 6)], "wc": [Box(7.58, 0, 9, 6)]}
    after, moves = slid(brief(rooms, weights={"cover": 0.1}), start)
    assert (moves, after) == (0, start)


def test_a_slide_keeps_the_rooms_constraints() -> None:
    # The bedroom would be at its target 4 m wide but its maximum is 3.5 m, and it must
    # keep 3 m of wall with the living room: it grows to 3.5 m and no further.
    p = brief([{"id": "living", "target_size": [6, 6]},
               {"id": "bed", "target_size": [4, 6], "max_size": [3.5, 6]}],
              adjacency=[{"a": "living", "b": "bed", "min_contact": 3}])
    start = {"living": [Box(0, 0, 6, 6)], "bed": [Box(6, 0, 9, 6)]}
    after, _ = slid(p, start)
    # A millimetre inside the bound: the output's precision.
    assert after == {"living": [Box(0, 0, 5.501, 6)], "bed": [Box(5.501, 0, 9, 6)]}
    assert check_layout(p, after).valid
