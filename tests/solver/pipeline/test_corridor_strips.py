"""Blocks cut into strips along their corridors (geometry only, no SCIP): an L-shaped
block (a column along one corridor joined to a row along another) gives one strip per
corridor, neither cut across, and the rooms are dealt no deeper than a cell."""

from __future__ import annotations

import shapely
from shapely.geometry import LineString, box

from floorplan.solver.network import grid_mesh
from floorplan.solver.pipeline.regions.corridors import _strips


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
