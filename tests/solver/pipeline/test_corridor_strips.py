"""Blocks cut into strips along their corridors (geometry only, no SCIP): an L-shaped
block (a column along one corridor joined to a row along another) gives one strip per
corridor, neither cut across, and the rooms are dealt no deeper than a cell."""

from __future__ import annotations

import shapely
from shapely.geometry import LineString, box

from floorplan.models import Problem
from floorplan.solver.network import Mesh, grid_mesh
from floorplan.solver.pipeline.regions.corridors import _strips, walkable_pitch


def test_an_l_shaped_block_gives_a_column_and_a_row() -> None:
    mesh = grid_mesh(box(0, 0, 20, 12), (4.0, 4.0))
    lines = [LineString([(4, 4), (4, 12)]), LineString([(4, 4), (20, 4)])]
    corridors = shapely.union_all(
        [ln.buffer(0.9, cap_style="square", join_style="mitre") for ln in lines]
    ).intersection(box(0, 0, 20, 12))
    block = box(0, 0, 20, 12).difference(corridors).difference(box(4.9, 4.9, 20, 12))
    strips, floor = _strips(block, mesh, corridors, 1.0)
    assert not floor
    assert len(strips) == 2
    grown = corridors.buffer(1e-4, join_style="mitre")
    for strip in strips:
        assert strip.boundary.intersection(grown).length > 3.0  # along its corridor
    tall = max(strips, key=lambda s: s.bounds[3] - s.bounds[1])
    wide = max(strips, key=lambda s: s.bounds[2] - s.bounds[0])
    assert tall.bounds[3] - tall.bounds[1] >= 8.0 and tall.bounds[2] <= 4.0
    assert wide.bounds[2] - wide.bounds[0] >= 15.0 and wide.bounds[3] <= 4.0
    assert abs(sum(s.area for s in strips) - block.area) < 1e-3


def test_a_grid_is_chosen_whose_every_cell_can_reach_an_exit() -> None:
    """Exits mid-south and mid-north of a 70 x 34 m floor, 45 m: at a 4.92 m pitch the
    cells at the middle of the side walls have no side within the walk (the IP would be
    infeasible); the pitch chosen nearby has every cell's side within reach, walked
    along x and y from the nearest exit (checked here)."""
    problem = Problem.model_validate({
        "name": "two-exits",
        "boundary": [[0, 0], [70, 0], [70, 34], [0, 34]],
        "rooms": [{"id": "a", "type": "shop", "target_size": [4.5, 3.5]}],
        "corridors": {"exits": [[35, 0], [35, 34]], "width": 1.8, "max_travel": 45},
    })
    corridors = problem.corridors
    assert corridors is not None
    cap = 45 - 0.9

    def reachable(mesh: Mesh) -> bool:
        def near(x: int) -> bool:
            (ax, ay), (bx, by) = (mesh.points[v] for v in mesh.edges[x])
            m = ((ax + bx) / 2, (ay + by) / 2)
            return min(abs(m[0] - e[0]) + abs(m[1] - e[1]) for e in corridors.exits) <= cap
        return all(any(near(x) for x in sides) for sides in mesh.faces)

    free = problem.free_area()
    assert not reachable(grid_mesh(free, (4.92, 4.02), anchors=corridors.exits))
    pitch, thinnest = walkable_pitch(problem, corridors, (4.92, 4.02))
    assert reachable(grid_mesh(free, pitch, anchors=corridors.exits, thinnest=thinnest))
    assert all(0.85 * a <= b <= 1.15 * a for a, b in zip((4.92, 4.02), pitch, strict=True))
