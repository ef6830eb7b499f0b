"""Joined, not chained: a 24 x 13 m floor with one exit mid-west, 6 m dead ends at most.
On the rooms' grid the network must be a loop, on the lines 2.6 m from the south and
north walls, and leaves rows 1.7 m deep there, thinner than any room may be (2.4 m).
The plan feeds that back: a second network on a grid with those lines moved a room's
depth from the walls, which leaves no such strip; the rooms are then laid out, each no
smaller than its `min_size` (real SCIP)."""

from __future__ import annotations

from shapely.geometry import Polygon

from floorplan.models import Problem
from floorplan.solver.pipeline.dispatch import solve
from floorplan.solver.pipeline.regions.corridor_feedback import least_side
from floorplan.solver.pipeline.regions.corridors import (
    _plan,
    _thin,
    network_spec,
    plan_corridors,
    room_pitch,
    walkable_pitch,
)

LEAST = 2.4


def _problem() -> Problem:
    return Problem.model_validate({
        "name": "thin-rows",
        "boundary": [[0, 0], [24, 0], [24, 13], [0, 13]],
        "rooms": [
            {"id": f"r{k}", "type": "office", "target_size": [4.0, 3.0],
             "min_size": [LEAST, LEAST]}
            for k in range(18)
        ],
        "corridors": {"exits": [[0, 6.5]], "width": 1.8, "max_travel": 40, "dead_ends": 6},
        "options": {"time_limit": 30, "seed": 0},
    })


def test_a_strip_no_room_fits_gets_a_second_network() -> None:
    problem = _problem()
    corridors = problem.corridors
    assert corridors is not None
    assert least_side(problem) == LEAST
    pitch, thinnest = walkable_pitch(problem, corridors, room_pitch(problem, corridors.width))
    first = _plan(problem, network_spec(problem, corridors, pitch, thinnest), 10.0, 0)
    assert first is not None
    assert _thin(first, LEAST)  # the chained plan: strips no room fits

    plan = plan_corridors(problem, 30.0)
    assert plan is not None
    assert plan.widened  # fed back
    assert not _thin(plan, LEAST)
    assert plan.shape.area < first.shape.area

    layout = solve(problem)
    assert layout.report.valid
    assert len(layout.rooms) == len(problem.rooms)
    for room in layout.rooms:
        x0, y0, x1, y1 = Polygon(room.polygon).bounds
        assert min(x1 - x0, y1 - y0) >= LEAST - 1e-6
