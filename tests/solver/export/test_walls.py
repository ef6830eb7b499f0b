"""The walls found from room polygons (solver/export/walls.py): built once, facade
closed, partitions where rooms meet."""

from __future__ import annotations

import itertools

import pytest
import shapely
from shapely.geometry import Polygon, box

from floorplan.models import Layout, Problem
from floorplan.solver.export.walls import (
    FACADE_THICKNESS,
    PARTITION_THICKNESS,
    WallSegment,
    wall_segments,
)
from tests.paths import EXAMPLES

#: An L-shaped flat: three rooms, the outline with a reflex corner at (6, 4).
L_OUTLINE = Polygon([(0, 0), (10, 0), (10, 4), (6, 4), (6, 8), (0, 8)])
L_ROOMS = {"a": box(0, 0, 6, 4), "b": box(6, 0, 10, 4), "c": box(0, 4, 6, 8)}


def house() -> tuple[Problem, Layout, list[WallSegment]]:
    problem = Problem.model_validate_json((EXAMPLES / "house-13.json").read_text())
    layout = Layout.model_validate_json((EXAMPLES / "house-13.layout.json").read_text())
    walls = wall_segments({r.id: Polygon(r.polygon) for r in layout.rooms}, problem.outline())
    return problem, layout, walls


def test_the_facade_closes_round_the_outline_convex_and_reflex_corners() -> None:
    walls = wall_segments(L_ROOMS, L_OUTLINE)
    facade = shapely.union_all([w.footprint() for w in walls if w.exterior])
    band = L_OUTLINE.buffer(FACADE_THICKNESS, join_style="mitre").difference(L_OUTLINE)
    assert facade.symmetric_difference(band).area == pytest.approx(0, abs=1e-9)
    # No overlap at the reflex corner, no gap at the convex ones.
    assert sum(w.footprint().area for w in walls if w.exterior) == pytest.approx(band.area)


def test_a_partition_per_pair_of_rooms_centred_on_their_shared_wall() -> None:
    walls = [w for w in wall_segments(L_ROOMS, L_OUTLINE) if not w.exterior]
    assert sorted(w.spaces for w in walls) == [("a", "b"), ("a", "c")]
    for wall in walls:
        assert wall.thickness == PARTITION_THICKNESS and wall.offset == -PARTITION_THICKNESS / 2
        shared = L_ROOMS[wall.spaces[0]].boundary.intersection(L_ROOMS[wall.spaces[1]].boundary)
        assert shapely.LineString(wall.edge).equals(shared)


def test_no_wall_is_built_twice_in_a_real_layout() -> None:
    _, layout, walls = house()
    corner = FACADE_THICKNESS**2
    for a, b in itertools.combinations(walls, 2):
        assert a.footprint().intersection(b.footprint()).area <= corner + 1e-9, (a, b)
    # Every stretch of wall two rooms share is a partition between them, once.
    shapes = {r.id: Polygon(r.polygon) for r in layout.rooms}
    for a, b in itertools.combinations(sorted(shapes), 2):
        shared = shapes[a].boundary.intersection(shapes[b].boundary).length
        built = sum(shapely.LineString(w.edge).length for w in walls if w.spaces == (a, b))
        assert built == pytest.approx(shared, abs=1e-6), (a, b)


def test_aisles_meet_without_walls_and_obstacles_get_none() -> None:
    outline = box(0, 0, 9, 3)
    spaces = {"room": box(0, 0, 3, 3), "aisle-1": box(3, 0, 6, 3), "aisle-2": box(6, 0, 9, 3)}
    walls = wall_segments(spaces, outline, circulation={"aisle-1", "aisle-2"})
    assert [w.spaces for w in walls if not w.exterior] == [("aisle-1", "room")]
    core = box(2, 2, 3, 3)  # in the corner: the room wraps it as an L
    rooms = {"room": box(0, 0, 3, 3).difference(core)}
    walls = wall_segments(rooms, box(0, 0, 3, 3), obstacles=[core])
    assert walls and all(w.exterior for w in walls)
    assert sum(w.length for w in walls) == pytest.approx(12 + 4 * FACADE_THICKNESS)
