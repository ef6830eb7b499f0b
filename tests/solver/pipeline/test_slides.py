"""A room moved across a gap no neighbour may grow into (solver.pipeline.floor._slid):
the levels' last resort before an answer short of the coverage goal."""

from __future__ import annotations

import time
from typing import Any

from floorplan.models import Problem
from floorplan.solver.geometry import Box, make_domain
from floorplan.solver.pipeline.absorb import absorb_gaps
from floorplan.solver.pipeline.floor import _slid
from floorplan.solver.pipeline.hierarchy import as_pieces, room_boxes
from floorplan.solver.pipeline.run import Run, covers

#   +----+-------------+-----------+  y 4
#   |gap | kitchen     | bedroom   |
#   |    | 4 m: its    | 3.3 m, up |
#   |    | largest     | to 4 m    |
#   +----+-------------+-----------+  y 0
#   0   0.7           4.7          8
ROOMS = {"kitchen": [Box(0.7, 0, 4.7, 4)], "bedroom": [Box(4.7, 0, 8, 4)]}


def problem(kitchen: dict[str, Any]) -> Problem:
    return Problem.model_validate({
        "boundary": [[0, 0], [8, 0], [8, 4], [0, 4]],
        "rooms": [
            {"id": "kitchen", "min_size": [3, 3], "max_size": [4, 4], "target_size": [4, 4],
             **kitchen},
            {"id": "bedroom", "min_size": [3, 3], "max_size": [4, 4], "target_size": [4, 4]},
        ],
        "adjacency": [{"a": "kitchen", "b": "bedroom"}],
    })


def slid(brief: Problem) -> dict[str, list[Box]]:
    domain = make_domain(brief)
    run = Run(brief, time.monotonic() + 10, time.monotonic(), None, None)
    pieces = absorb_gaps(brief, domain, as_pieces(ROOMS))
    assert not covers(domain, room_boxes(pieces))  # the kitchen may not grow: a gap stays
    return room_boxes(_slid(run, domain, pieces))


def test_a_room_at_its_largest_moves_across_the_gap_and_its_neighbour_takes_the_rest() -> None:
    rooms = slid(problem({}))
    assert rooms["kitchen"] == [Box(0, 0, 4, 4)]
    assert rooms["bedroom"] == [Box(4, 0, 8, 4)]  # the strip the kitchen left


def test_no_move_that_breaks_the_brief() -> None:
    # A guide point the kitchen would leave behind.
    rooms = slid(problem({"positions": [[4.5, 2]]}))
    assert rooms["kitchen"] == [Box(0.7, 0, 4.7, 4)]
