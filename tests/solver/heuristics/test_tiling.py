"""Exact tilings by the targets (docs/method.md, "Whole layouts by guillotine cuts"):
rooms whose sides match joined into the floor's rectangles, an L room's two parts fixed
by what they join."""

from __future__ import annotations

import math

import pytest

from bench.planted import draw
from floorplan.solver.heuristics.tiling import (
    HORIZONTAL,
    VERTICAL,
    Fillers,
    Tiling,
    _Search,
    tilings,
)

#: A 12 x 12 m floor cut exactly by ten rooms: a 12 x 2 strip of three along the south,
#: a 4 x 10 column of two, and an 8 x 10 block of five.
TEN = [(4, 3), (4, 7), (5, 4), (3, 4), (2, 6), (6, 3), (6, 3), (3, 2), (3, 2), (6, 2)]


def test_ten_rooms_that_tile_the_floor_are_joined_into_it() -> None:
    found = tilings(TEN, [(0.0, 0.0, 12.0, 12.0)], limit=2, deadline=math.inf)
    assert found
    fit = found[0]
    assert not fit.shaped
    assert sorted(t for t in fit.tokens if t >= 0) == list(range(10))
    assert sum(t in (VERTICAL, HORIZONTAL) for t in fit.tokens) == 9


def test_an_l_room_is_found_with_the_sides_of_its_two_parts() -> None:
    # 10 x 8: a bedroom of 6 x 4 in a corner, the living room an L around it (its box the
    # whole floor, 56 m²): its parts 10 x 4 and 4 x 4, or 4 x 8 and 6 x 4.
    found = tilings([(10, 8), (6, 4)], [(0.0, 0.0, 10.0, 8.0)], limit=4, deadline=math.inf)
    assert found
    fit = found[0]
    assert fit.shaped == {0}
    parts = sorted([fit.parts[0], fit.parts[2]])
    areas = sorted(w * d for w, d in parts)
    assert sum(areas) == pytest.approx(56)


def test_no_tiling_when_the_targets_ask_for_less_than_the_floor() -> None:
    assert tilings([(3, 3), (3, 3)], [(0.0, 0.0, 10.0, 10.0)], limit=1,
                   deadline=math.inf) == []


def test_an_outline_of_two_rectangles_is_tiled_piece_by_piece() -> None:
    # An L outline: 8 x 4 below, 4 x 4 above its west half.
    pieces = [(0.0, 0.0, 8.0, 4.0), (0.0, 4.0, 4.0, 8.0)]
    found = tilings([(4, 4), (4, 4), (4, 4)], pieces, limit=1, deadline=math.inf)
    assert found
    assert found[0].tokens[-1] == HORIZONTAL  # the line between the two pieces


def test_an_l_whose_parts_join_other_rooms_first_is_found() -> None:
    # A 6.8 x 7.3 box with its south-west corner (2.8 x 2.6) outside the outline. The
    # bedroom is an L (box 2.8 x 4.7): its bar, 2.8 x 1.85, stands on the void; its arm,
    # 2.2 x 2.85, beside the 4.6 x 2.85 room above the 4.0 x 4.45 living room. Neither
    # part joins the other until the whole floor is joined.
    targets = [(4.0, 4.45), (4.6, 2.85), (2.8, 4.7)]
    found = tilings(targets, [(0.0, 0.0, 6.8, 7.3)], voids=[(0.0, 0.0, 2.8, 2.6)], limit=1,
                    deadline=math.inf)
    assert found
    fit = found[0]
    assert fit.shaped == {2}
    assert fit.parts[2] == pytest.approx((2.8, 1.85))
    assert fit.parts[5] == pytest.approx((2.2, 2.85))


#: A 10 x 10 box whose north-east 4 x 4 lies outside the outline. A 3 x 5 room's cell
#: crosses into that corner (the room is an L once cut to the outline), so the corner's
#: rest is two cells no room takes, 2 x 2 and 2 x 4.
CORNER_CUT = [(5, 10), (5, 3), (3, 5), (2, 3), (1, 2)]


def test_two_cells_left_outside_the_outline_are_two_fillers() -> None:
    found = tilings(CORNER_CUT, [(0.0, 0.0, 10.0, 10.0)], limit=3, deadline=math.inf,
                    fillers=Fillers(2, (4.0, 4.0), 16.0))
    assert found
    for fit in found:
        fillers = [fit.parts[leaf] for leaf in fit.parts if leaf >= 2 * len(CORNER_CUT)]
        assert len(fillers) == 2
        assert sum(w * d for w, d in fillers) == pytest.approx(12)
    assert tilings(CORNER_CUT, [(0.0, 0.0, 10.0, 10.0)], limit=1, deadline=math.inf,
                   fillers=Fillers(1, (4.0, 4.0), 16.0)) == []


def test_a_filler_is_no_larger_than_the_part_outside_the_outline() -> None:
    assert tilings(CORNER_CUT, [(0.0, 0.0, 10.0, 10.0)], limit=1, deadline=math.inf,
                   fillers=Fillers(2, (1.5, 4.0), 16.0)) == []


#: The top row of a T-shaped outline drawn on its 9.35 m wide box (planted-07-6838): a
#: corridor and a kitchen between the two 2.4 m wide corners outside the outline.
T_TOP_ROW = [(1.35, 4.2), (3.2, 4.2)]
T_CORNERS = ((2.4, 4.85), (2.4, 4.85))


def test_two_fillers_in_one_row_take_the_sides_of_the_parts_outside() -> None:
    found = tilings(T_TOP_ROW, [(0.0, 0.0, 9.35, 4.2)], limit=4, deadline=math.inf,
                    fillers=Fillers(2, (2.4, 4.85), 23.28, T_CORNERS))
    assert found
    for fit in found:
        fillers = [fit.parts[leaf] for leaf in fit.parts if leaf >= 2 * len(T_TOP_ROW)]
        assert fillers == [pytest.approx((2.4, 4.2))] * 2
    # Fillers of open sides only: two unknowns along the row, no tiling.
    assert tilings(T_TOP_ROW, [(0.0, 0.0, 9.35, 4.2)], limit=1, deadline=math.inf,
                   fillers=Fillers(2, (2.4, 4.85), 23.28)) == []


def test_rooms_that_tile_the_floor_exactly_are_found_whatever_the_rounding() -> None:
    # 2.15 x 3 and 4.45 x 3 over-ask a 6.6 x 3 floor by 3.6e-15 m² in floating point:
    # with no room an L, there is no notch for the notch bound to hold that to.
    assert tilings([(2.15, 3.0), (4.45, 3.0)], [(0.0, 0.0, 6.6, 3.0)], limit=1,
                   deadline=math.inf)


def test_the_floor_a_guess_over_asks_bounds_its_ls_notches() -> None:
    # planted-14-6831: fourteen rooms on a rectangle, the living room and bedroom7 drawn
    # as Ls (both bars running north-south). Their notches add up to the floor the
    # targets over-ask; a join that fixes them beyond it is cut, and the plan's guess is
    # tiled within a budget of joins that the search without the bound exhausts.
    problem, _ = draw(6831)
    ids = [room.id for room in problem.rooms]
    targets = [room.target_size for room in problem.rooms]
    assert all(t is not None for t in targets)
    xs, ys = zip(*problem.boundary, strict=True)
    floor = (min(xs), min(ys), max(xs), max(ys))
    over = sum(w * d for w, d in targets) - (floor[2] - floor[0]) * (floor[3] - floor[1])
    guess = frozenset({(ids.index("living1"), True), (ids.index("bedroom7"), True)})

    def search(notches: tuple[float, float] | None) -> list[Tiling]:
        return _Search(targets, [floor], guess, math.inf, 1, 60_000,
                       notches=notches).run()

    assert len(problem.rooms) == 14 and over > 0
    found = search((over, over))
    assert found and found[0].shaped == {ids.index("living1"), ids.index("bedroom7")}
    assert search(None) == []
