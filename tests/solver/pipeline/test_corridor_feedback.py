"""Joined, not chained: a 24 x 13 m floor with one exit mid-west, 6 m dead ends at most.
On the rooms' grid the network must be a loop, on the lines 2.6 m from the south and
north walls, and leaves rows 1.7 m deep there, thinner than any room may be (2.4 m).
The plan feeds that back: a second network on a grid with those lines moved a room's
depth from the walls, which leaves no such strip; the rooms are then laid out, each no
smaller than its `min_size` (real SCIP)."""

from __future__ import annotations

from shapely.geometry import Polygon, box

from floorplan.models import Problem
from floorplan.solver.network import grid_mesh
from floorplan.solver.network.mesh import without
from floorplan.solver.pipeline.dispatch import solve
from floorplan.solver.pipeline.regions.corridor_feedback import (
    forbidden_edges,
    least_side,
    widening,
)
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


def test_an_anchored_line_keeps_its_place_and_its_edges_along_the_strip_go() -> None:
    """Geometry only: a 20 x 12 m grid at 4 m with lines run from an exit at (0, 2.6), a
    corridor on y = 2.6 from the exit to x = 12 leaving a 1.7 m strip south of it. As a
    free line, it moves to 4 m (the pitch) from the strip's far side; as an exit's line,
    it stays and its edges along the strip are forbidden, but the one at the exit."""
    mesh = grid_mesh(box(0, 0, 20, 12), (4.0, 4.0), anchors=[(0.0, 2.6)])
    assert 2.6 in mesh.ys
    along = [x for x, (i, j) in enumerate(mesh.edges)
             if all(abs(mesh.points[v][1] - 2.6) < 1e-9 for v in (i, j))
             and max(mesh.points[i][0], mesh.points[j][0]) <= 12.0 + 1e-9]
    sink = mesh.nearest((0.0, 2.6))
    strip = box(0.0, 0.0, 12.9, 1.7)
    free = widening(mesh, along, [sink], [(strip, 1)], 1.8, ([], []), (4.0, 4.0))
    assert free.moved == ((), ((2.6, 4.0),)) and not free.forbid
    anchored = widening(mesh, along, [sink], [(strip, 1)], 1.8, ([], [2.6]), (4.0, 4.0))
    assert not anchored.moved[1]
    forbidden = forbidden_edges(mesh, anchored.forbid)
    # Every edge of the line beside the strip (to 12.9 m), but the one at the exit.
    beside = [x for x, (i, j) in enumerate(mesh.edges)
              if all(abs(mesh.points[v][1] - 2.6) < 1e-9 for v in (i, j))
              and min(mesh.points[i][0], mesh.points[j][0]) < 12.9 and sink not in (i, j)]
    assert sorted(forbidden) == sorted(beside) and set(along) - set(forbidden) == {
        x for x in along if sink in mesh.edges[x]}
    assert without(mesh, forbidden).edges == [
        e for x, e in enumerate(mesh.edges) if x not in forbidden]
