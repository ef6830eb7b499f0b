"""Sliding whole walls (issue 19): a wall several rooms share, or a rectangle between
two others, moves where the rooms' targets ask, and no room overlaps another, loses
floor to a gap or breaks a constraint for it."""

from __future__ import annotations

import time
from typing import Any

from models import Problem
from solver.geometry import Box, make_domain
from solver.heuristics.wall_slide import slide_walls
from solver.verify.checker import check_layout

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


def test_walls_on_the_outline_or_beside_a_gap_stay() -> None:
    # The bedroom's east wall borders a gap 1 m wide: moving it would uncover floor or
    # cover the gap's, so it stays though the bedroom is 1 m short of its target; the
    # wall it shares with the living room may move (the two split the shortfall).
    p = brief([{"id": "living", "target_size": [5, 6]}, {"id": "bed", "target_size": [4, 6]}])
    start = {"living": [Box(0, 0, 5, 6)], "bed": [Box(5, 0, 8, 6)]}
    after, _ = slid(p, start)
    (living,), (bed,) = after["living"], after["bed"]
    assert (living.x0, bed.x1) == (0, 8) and living.x1 == bed.x0
    assert check_layout(p, after).coverage == check_layout(p, start).coverage


def test_a_slide_keeps_the_rooms_constraints() -> None:
    # The bedroom would be at its target 4 m wide but its maximum is 3.5 m, and it must
    # keep 3 m of wall with the living room: it grows to 3.5 m and no further.
    p = brief([{"id": "living", "target_size": [6, 6]},
               {"id": "bed", "target_size": [4, 6], "max_size": [3.5, 6]}],
              adjacency=[{"a": "living", "b": "bed", "min_contact": 3}])
    start = {"living": [Box(0, 0, 6, 6)], "bed": [Box(6, 0, 9, 6)]}
    after, _ = slid(p, start)
    assert after == {"living": [Box(0, 0, 5.5, 6)], "bed": [Box(5.5, 0, 9, 6)]}
    assert check_layout(p, after).valid
