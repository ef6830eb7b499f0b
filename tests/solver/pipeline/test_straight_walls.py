"""The answer's walls lined up (solver.pipeline.assemble.straight_walls): no jog or
sliver thinner than a wall, unless lining it up breaks what the brief asks."""

from __future__ import annotations

from typing import Any

from floorplan.models import Problem
from floorplan.solver.geometry import Box
from floorplan.solver.pipeline.assemble import straight_walls
from floorplan.solver.verify.checker import check_layout

#   +----------+------+  y 8 (the bath stops at 7.99; the bed takes the 1 cm strip above it)
#   |  bed     | bath |
#   +----------+------+  y 4
#   |  living         |
#   +-----------------+  y 0
ROOMS = {
    "living": [Box(0, 0, 8, 4)],
    "bed": [Box(0, 4, 6, 8), Box(6, 7.99, 8, 8)],
    "bath": [Box(6, 4, 8, 7.99)],
}


def problem(bath_depth: float) -> Problem:
    data: dict[str, Any] = {
        "boundary": [[0, 0], [8, 0], [8, 8], [0, 8]],
        "rooms": [
            {"id": "living", "min_size": [3, 3], "max_size": [8, 4], "target_size": [8, 4]},
            {"id": "bed", "min_size": [3, 3], "max_size": [8, 4], "target_size": [6, 4]},
            {"id": "bath", "min_size": [1.5, 1.5], "max_size": [2, bath_depth],
             "target_size": [2, 3.99]},
        ],
    }
    return Problem.model_validate(data)


def test_a_sliver_along_the_facade_goes_and_the_walls_line_up() -> None:
    brief = problem(bath_depth=4.0)
    check = check_layout(brief, ROOMS)
    assert check.valid
    rooms, again = straight_walls(brief, ROOMS, check)
    assert again.valid and again.coverage >= check.coverage
    assert rooms["bed"] == [Box(0, 4, 6, 8)]  # the 1 cm strip is gone ...
    assert rooms["bath"] == [Box(6, 4, 8, 8)]  # ... and the bath reaches the facade


def test_walls_stay_where_lining_them_up_breaks_the_brief() -> None:
    brief = problem(bath_depth=3.99)  # the bath may not be any deeper
    check = check_layout(brief, ROOMS)
    assert check.valid
    rooms, again = straight_walls(brief, ROOMS, check)
    assert rooms is ROOMS and again is check


def test_each_jog_that_can_go_goes_when_not_all_of_them_can() -> None:
    # The living room split in two 3 cm off the bed's wall above: that jog goes, though
    # the bath (no deeper than 3.99 m) keeps the bed's 1 cm strip beside it.
    brief = Problem.model_validate({**problem(bath_depth=3.99).model_dump(), "rooms": [
        *problem(bath_depth=3.99).model_dump()["rooms"],
        {"id": "hall", "min_size": [1.5, 1.5], "max_size": [3, 4], "target_size": [2, 4]}]})
    rooms = {**ROOMS, "living": [Box(0, 0, 6.03, 4)], "hall": [Box(6.03, 0, 8, 4)]}
    check = check_layout(brief, rooms)
    assert check.valid
    lined, again = straight_walls(brief, rooms, check)
    assert again.valid
    assert {b.x0 for b in lined["hall"]} == {b.x1 for b in lined["living"]} == {6.0}
    assert lined["bath"] == ROOMS["bath"] and lined["bed"] == ROOMS["bed"]
