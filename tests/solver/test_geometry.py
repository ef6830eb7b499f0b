"""Properties of the geometry helpers the MIQP relies on for soundness."""

from __future__ import annotations

import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from floorplan.models import Problem
from floorplan.solver.geometry import (
    Box,
    boundary_edges,
    edges_named,
    rectangles_of,
    unusable_space,
    wall_moves,
    walls_moved,
)

REGION = Box(0, 0, 10, 10)

walls = st.lists(
    st.builds(
        lambda x, y, w, d: Box(x, y, x + w, y + d),
        st.floats(0, 8), st.floats(0, 8), st.floats(0.2, 3), st.floats(0.2, 3),
    ),
    min_size=1, max_size=7,
)


def _union(boxes: tuple[Box, ...] | list[Box]) -> shapely.Geometry:
    return shapely.union_all([b.to_polygon() for b in boxes])


@settings(max_examples=150, deadline=None)
@given(walls, st.floats(0.3, 2.0))
def test_unusable_space_blocks_every_wall(boxes: list[Box], side: float) -> None:
    wall = _union(boxes).intersection(REGION.to_polygon())
    blocked = _union(unusable_space(REGION, boxes, side))
    assert wall.difference(blocked).area < 1e-6


@settings(max_examples=150, deadline=None)
@given(walls, st.floats(0.3, 2.0), st.floats(0, 1), st.floats(0, 1))
def test_unusable_space_never_blocks_a_square_a_room_could_use(
    boxes: list[Box], side: float, fx: float, fy: float
) -> None:
    x, y = fx * (REGION.width - side), fy * (REGION.depth - side)
    square = Box(x, y, x + side, y + side).to_polygon()
    if square.intersection(_union(boxes)).area > 1e-12:
        return  # not usable in the first place
    blocked = _union(unusable_space(REGION, boxes, side))
    assert square.intersection(blocked).area < 1e-6


@settings(max_examples=150, deadline=None)
@given(walls)
def test_rectangles_of_a_union_cover_it_without_overlap(boxes: list[Box]) -> None:
    union = _union(boxes)
    pieces = rectangles_of(union)
    assert abs(sum(p.area for p in pieces) - union.area) < 1e-6
    assert _union(pieces).symmetric_difference(union).area < 1e-6


cuts = st.lists(st.floats(0.01, 9.99), min_size=1, max_size=6)


@settings(max_examples=150, deadline=None)
@given(cuts, cuts, st.floats(0.01, 0.5))
def test_walls_lined_up_still_tile_the_floor(xs: list[float], ys: list[float],
                                             tol: float) -> None:
    # A grid of rooms, some of its lines a few centimetres apart: lining them up keeps
    # the floor covered once, and the outline's lines where they are.
    gx, gy = [0.0, *sorted(xs), 10.0], [0.0, *sorted(ys), 10.0]
    rooms = {f"{i},{j}": [Box(gx[i], gy[j], gx[i + 1], gy[j + 1])]
             for i in range(len(gx) - 1) for j in range(len(gy) - 1)
             if gx[i + 1] > gx[i] and gy[j + 1] > gy[j]}
    lined = walls_moved(rooms, wall_moves(rooms, [0.0, 10.0], [0.0, 10.0], tol))
    boxes = [b for rects in lined.values() for b in rects]
    assert abs(sum(b.area for b in boxes) - 100.0) < 1e-6  # no overlap ...
    assert abs(_union(boxes).area - 100.0) < 1e-6  # ... and no gap
    assert min(b.x0 for b in boxes) == 0.0 and max(b.x1 for b in boxes) == 10.0


def test_a_rectangle_scip_stopped_just_short_of_a_notch_is_cut_round_it() -> None:
    from floorplan.solver.geometry import Notch
    from floorplan.solver.geometry.domain import unwrapped

    # apartment-15-obstacles under load: bed1 wrapped round the shaft on the north wall,
    # its top 1.9e-6 short of the outline (SCIP's tolerance, relative to 11.5 m).
    shaft = Box(11.6, 10.3, 12.6, 11.5)
    notch = Notch(shaft, Box(11.1, 9.8, 13.1, 11.5))
    bed1 = Box(10.200001024314936, 6.699998219593062, 15.0, 11.49999808263868)
    parts = unwrapped(bed1, [notch])
    assert len(parts) > 1
    floor = shapely.union_all([p.to_polygon() for p in parts])
    assert floor.intersection(shaft.to_polygon()).area < 1e-9
    assert floor.area == pytest.approx(bed1.to_polygon().area - 1.2, abs=1e-4)


def test_compass_words_name_the_sides_facing_the_problems_north() -> None:
    # An L: edges 0 south, 1 east, 2 north (the cut), 3 east (the cut), 4 north, 5 west.
    ring = [(0, 0), (6, 0), (6, 3), (4, 3), (4, 5), (0, 5)]
    edges = boundary_edges(ring)

    def named(north: float, words: list[str | int]) -> list[int]:
        problem = Problem.model_validate({"boundary": ring, "rooms": [{"id": "a"}],
                                          "north": north})
        return [e.index for e in edges_named(problem, edges, words)]

    assert named(0, ["north"]) == [2, 4] and named(0, ["east"]) == [1, 3]
    assert named(90, ["north"]) == [1, 3]  # north along +x: the plan's east sides
    assert named(90, ["south"]) == [5] and named(90, ["west"]) == [2, 4]
    assert named(180, ["north"]) == [0]
    assert named(45, ["north"]) == [1, 2, 3, 4]  # halfway: both words name the side
    assert named(30, ["north", 0]) == [0, 2, 4]  # indices stay indices
