"""The reshaping (docs/method.md, "The steps", step 6): strips of floor move between
neighbours, rooms become L or T where that brings them nearer their targets, and no
constraint is broken for it."""

from __future__ import annotations

import random
import time
from typing import Any

import pytest
import shapely
from shapely.geometry import box

from floorplan.models import Problem
from floorplan.solver.geometry import Box, make_domain, rectangles_of
from floorplan.solver.heuristics.level_one import unfitting_targets
from floorplan.solver.heuristics.reshape import reshape
from floorplan.solver.heuristics.reshape.strips import strip_extent
from floorplan.solver.pipeline.run import layout_objective
from floorplan.solver.verify.checker import check_layout

Rooms = dict[str, list[Box]]


def brief(rooms: list[dict[str, Any]], **fields: Any) -> Problem:
    return Problem.model_validate({"boundary": [[0, 0], [9, 0], [9, 6], [0, 6]],
                                   "rooms": rooms, **fields})


def reshaped(problem: Problem, rooms: Rooms, seconds: float = 2.0, seed: int = 0) -> Rooms:
    result = reshape(problem, make_domain(problem), rooms,
                     deadline=time.monotonic() + seconds, seed=seed)
    return result.rooms


def corners(boxes: list[Box]) -> int:
    shape = shapely.union_all([b.to_polygon() for b in boxes]).simplify(0)
    return len(shape.exterior.coords) - 1


def area(boxes: list[Box]) -> float:
    return float(shapely.union_all([b.to_polygon() for b in boxes]).area)


def test_a_stretched_room_gives_its_neighbour_the_floor_it_lacks() -> None:
    # Both rectangles, the wall between them 2 m off: sliding it is the answer.
    p = brief([{"id": "a", "target_size": [3, 6]}, {"id": "b", "target_size": [6, 6]}])
    start = {"a": [Box(0, 0, 5, 6)], "b": [Box(5, 0, 9, 6)]}
    after = reshaped(p, start)
    # Either side of the plan: the rooms may also trade places.
    assert sorted((len(after[r]), after[r][0].width, after[r][0].depth) for r in "ab") == [
        (1, 3, 6), (1, 6, 6)]
    assert check_layout(p, after).coverage == 1.0


def test_a_room_becomes_an_l_where_its_targets_ask_for_one() -> None:
    # The bedroom (target 4 x 3) fills the east side; the living room's target is the
    # whole outline: it takes the bedroom's south half, or the bedroom moves into one of
    # its corners, and becomes an L.
    p = brief([{"id": "living", "target_size": [9, 6]},
               {"id": "bed", "target_size": [4, 3]}],
              adjacency=[{"a": "living", "b": "bed"}])
    domain = make_domain(p)
    start = {"living": [Box(0, 0, 5, 6)], "bed": [Box(5, 0, 9, 6)]}
    after = reshaped(p, start)
    (bed,) = after["bed"]
    assert (bed.width, bed.depth) == (4, 3) and bed.x0 in (0, 5) and bed.y0 in (0, 3)
    assert corners(after["living"]) == 6 and area(after["living"]) == 42
    assert layout_objective(p, domain, after) == 0.0
    assert layout_objective(p, domain, start) > 0.0


def test_a_small_room_moves_into_a_corner_of_the_living_room_and_frees_its_place() -> None:
    # The wc (target 2 x 3) shares the east column with the bedroom (target 3 x 6),
    # both 3 x 3. No strip between them helps: the wc must leave. Set into a corner of
    # the living room (target 6 x 6 on its bounding box), it makes the living room an
    # L, and the bedroom takes the whole column: every room at its target.
    p = brief([{"id": "living", "target_size": [6, 6]},
               {"id": "bed", "target_size": [3, 6]},
               {"id": "wc", "target_size": [2, 3]}])
    domain = make_domain(p)
    start = {"living": [Box(0, 0, 6, 6)], "bed": [Box(6, 0, 9, 3)], "wc": [Box(6, 3, 9, 6)]}
    after = reshaped(p, start)
    assert layout_objective(p, domain, start) == 10.0
    assert layout_objective(p, domain, after) == pytest.approx(0.0, abs=1e-6)
    # Where each ends up depends on the annealing (rooms may also trade places).
    assert [(b.width, b.depth) for b in after["bed"]] == [(3, 6)]
    assert [(b.width, b.depth) for b in after["wc"]] in ([(2, 3)], [(3, 2)])
    assert corners(after["living"]) == 6 and area(after["living"]) == 30
    assert check_layout(p, after).coverage == 1.0


def test_no_step_breaks_a_constraint_the_layout_met() -> None:
    # As above, but the bedroom must keep the point (7, 1) and touch the south wall,
    # and a study must keep its wall with it: the bedroom cannot give its south half.
    p = brief([{"id": "living", "target_size": [9, 6]},
               {"id": "bed", "target_size": [4, 3], "positions": [[7, 1]],
                "boundary": ["south"], "min_size": [3, 3], "max_size": [4, 6]}],
              adjacency=[{"a": "living", "b": "bed", "min_contact": 2}])
    start = {"living": [Box(0, 0, 5, 6)], "bed": [Box(5, 0, 9, 6)]}
    assert check_layout(p, start).valid
    after = reshaped(p, start)
    check = check_layout(p, after)
    assert check.valid, [c for c in check.constraints if not c.satisfied]
    assert check.coverage == 1.0
    assert after["bed"] == [Box(5, 0, 9, 3)]  # it gave the north half instead


def test_a_rectangle_that_must_stay_one_stays_one() -> None:
    p = brief([{"id": "living", "target_size": [9, 6]},
               {"id": "bed", "target_size": [4, 3], "max_rects": 1},
               {"id": "study", "target_size": [2, 2], "max_rects": 1}])
    start = {"living": [Box(0, 0, 5, 6)], "bed": [Box(5, 0, 9, 4)], "study": [Box(5, 4, 9, 6)]}
    after = reshaped(p, start)
    assert corners(after["bed"]) == 4 and corners(after["study"]) == 4
    assert check_layout(p, after).coverage == 1.0


def test_the_same_seed_gives_the_same_shapes() -> None:
    p = brief([{"id": "a", "target_size": [4, 4]}, {"id": "b", "target_size": [5, 2]},
               {"id": "c", "target_size": [3, 3]}])
    start = {"a": [Box(0, 0, 3, 6)], "b": [Box(3, 0, 9, 3)], "c": [Box(3, 3, 9, 6)]}
    assert reshaped(p, start, seed=4) == reshaped(p, start, seed=4)


def test_a_layout_with_a_hole_in_a_room_is_left_alone() -> None:
    # Rectangles that do not form one polygon: nothing to reshape safely.
    p = brief([{"id": "a", "target_size": [4, 4]}, {"id": "b", "target_size": [4, 4]}])
    start = {"a": [Box(0, 0, 2, 6), Box(7, 0, 9, 6)], "b": [Box(2, 0, 7, 6)]}
    result = reshape(p, make_domain(p), start, deadline=time.monotonic() + 1)
    assert result.rooms == start and result.steps == 0


def test_a_target_that_fits_nowhere_as_a_rectangle_starts_with_a_wing() -> None:
    # A T-shaped flat: 4.2 x 7.85 m fits only where the outline is 7.85 m tall, in an
    # arm 2.65 m wide; the bedroom's 3 x 3 fits anywhere.
    p = Problem.model_validate({
        "boundary": [[0, 0], [10.45, 0], [10.45, 5.35], [6.55, 5.35], [6.55, 7.85],
                     [3.9, 7.85], [3.9, 5.35], [0, 5.35]],
        "rooms": [{"id": "living", "target_size": [4.2, 7.85]},
                  {"id": "bed", "target_size": [3, 3]},
                  {"id": "store", "target_size": [4.2, 7.85], "max_rects": 1}]})
    assert unfitting_targets(p, make_domain(p)) == ["living"]  # store must stay one


def test_a_strip_is_measured_without_shapely_as_shapely_measures_it() -> None:
    # The annealing refuses most strips from their area and bounding boxes alone
    # (`strip_extent`); a wrong measure would refuse steps it should take.
    rng = random.Random(7)
    for _ in range(400):
        # A random L or T: a base rectangle and one or two arms on top of it.
        x0, w, d = rng.uniform(0, 3), rng.uniform(1, 5), rng.uniform(1, 4)
        parts = [box(x0, 0, x0 + w, d)]
        for _ in range(rng.choice((1, 2))):
            a0 = rng.uniform(x0, x0 + w - 0.5)
            parts.append(box(a0, d, rng.uniform(a0 + 0.3, x0 + w), d + rng.uniform(0.5, 3)))
        room = shapely.union_all(parts)
        (cx0, cx1), (cy0, cy1) = (sorted(rng.uniform(-1, 9) for _ in range(2)),
                                  sorted(rng.uniform(-1, 8) for _ in range(2)))
        cut = (cx0, cy0, cx1, cy1)
        pieces = [(p.x0, p.y0, p.x1, p.y1) for p in rectangles_of(room)]
        measured = strip_extent(pieces, cut)
        strip = room.intersection(box(*cut))
        if strip.area <= 1e-8:
            assert measured is None
            continue
        assert measured is not None
        taken, strip_bounds, rest_bounds = measured
        assert taken == pytest.approx(strip.area, abs=1e-6)
        assert strip_bounds == pytest.approx(strip.bounds, abs=1e-6)
        rest = room.difference(box(*cut))
        if rest.area <= 1e-9:
            assert rest_bounds is None
        else:
            assert rest_bounds == pytest.approx(rest.bounds, abs=1e-6)
