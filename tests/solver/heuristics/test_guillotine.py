"""The guillotine search (docs/method.md, "Whole layouts by guillotine cuts"): whole
layouts as slicing trees, with L and T rooms where the floor needs them, valid by the
checker and repeatable for a seed."""

from __future__ import annotations

import random

import pytest

from bench.planted import draw
from floorplan.models import Problem
from floorplan.solver.geometry import make_domain
from floorplan.solver.heuristics.guillotine import (
    MAX_TILED_ROOMS,
    anneal,
    applies,
    guillotine_layout,
    moves,
    score,
    tree,
)
from floorplan.solver.heuristics.guillotine.brief import (
    HORIZONTAL,
    VERTICAL,
    Brief,
    State,
    boxed_models,
    make_brief,
)
from floorplan.solver.heuristics.guillotine.tree import cut_region
from floorplan.solver.openings import connection_demands
from floorplan.solver.pipeline.run import covers, layout_objective
from floorplan.solver.verify.checker import check_layout


def l_living_brief() -> Problem:
    """A 10 x 8 m flat whose only answer at the targets has the living room as an L
    (10 x 8 bounding box) around a 6 x 4 m bedroom in the north-east corner."""
    return Problem.model_validate({
        "boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
        "rooms": [
            {"id": "living", "type": "living", "target_size": [10, 8], "min_size": [3, 3],
             "max_size": [10, 8], "positions": [[5, 0.5]]},
            {"id": "bed", "type": "bedroom", "target_size": [6, 4], "min_size": [3, 3],
             "max_size": [7, 5], "boundary": ["north", "east"]},
        ],
        "adjacency": [{"a": "living", "b": "bed", "min_contact": 0.9}],
    })


def test_an_l_shaped_living_room_around_a_bedroom_at_its_target() -> None:
    problem = l_living_brief()
    found = guillotine_layout(problem, make_domain(problem), seed=1, steps=3000,
                              accept=lambda rooms: check_layout(problem, rooms).valid)
    assert found is not None
    living, bed = found.rooms["living"], found.rooms["bed"]
    assert len(living) == 2  # an L
    assert sum(b.area for b in bed) == pytest.approx(24, rel=0.02)
    xs = [v for b in living for v in (b.x0, b.x1)]
    ys = [v for b in living for v in (b.y0, b.y1)]
    assert max(xs) - min(xs) == pytest.approx(10, abs=0.05)
    assert max(ys) - min(ys) == pytest.approx(8, abs=0.05)
    assert check_layout(problem, found.rooms).valid
    assert layout_objective(problem, make_domain(problem), found.rooms) < 0.01


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2001, 2008])
def test_a_planted_brief_gets_a_valid_covering_layout_and_a_seed_gives_one(seed: int) -> None:
    problem, _ = draw(seed, rooms=7)
    problem = connection_demands(problem)
    domain = make_domain(problem)
    found = guillotine_layout(problem, domain, seed=3, steps=8000,
                              accept=lambda rooms: check_layout(problem, rooms).valid)
    assert found is not None
    assert check_layout(problem, found.rooms).valid
    assert covers(domain, found.rooms)
    again = guillotine_layout(problem, domain, seed=3, steps=8000,
                              accept=lambda rooms: check_layout(problem, rooms).valid)
    assert again is not None and again.rooms == found.rooms


def test_a_cut_shares_an_l_shaped_region_by_area() -> None:
    region = [(0.0, 0.0, 10.0, 4.0), (0.0, 4.0, 4.0, 8.0)]  # 40 + 16 m²
    left, right = cut_region(region, True, 0.5)  # 28 m² each side
    area = sum((r[2] - r[0]) * (r[3] - r[1]) for r in left)
    assert area == pytest.approx(28)
    assert sum((r[2] - r[0]) * (r[3] - r[1]) for r in right) == pytest.approx(28)
    # The line runs at x = 3.5: 3.5 x 8 on the left is 28.
    assert max(r[2] for r in left) == pytest.approx(3.5)
    below, above = cut_region(region, False, 0.25)  # 14 m² below: y = 1.4
    assert below == [(0.0, 0.0, 10.0, pytest.approx(1.4))]
    assert len(above) == 2


def test_a_leaf_dropped_with_its_cut_leaves_a_tree() -> None:
    rng = random.Random(0)
    for _ in range(200):
        n = rng.randint(2, 8)
        state = tree.initial(
            Brief(tuple(map(str, range(n))), (), (), (), 0.0), rng)
        tokens = state.tokens
        leaf = rng.choice([p for p, t in enumerate(tokens) if t >= 0])
        dropped = tokens[leaf]
        moves._drop_leaf(tokens, leaf)
        assert moves._valid_postfix(tokens)
        assert dropped not in tokens
        assert sum(t >= 0 for t in tokens) == n - 1
        assert set(tokens) - {VERTICAL, HORIZONTAL} == set(range(n)) - {dropped}


def test_left_to_the_other_searches_where_it_does_not_apply() -> None:
    problem = l_living_brief()
    assert applies(problem, make_domain(problem))
    with_obstacle = Problem.model_validate({
        **problem.model_dump(), "obstacles": [{"x": 4.5, "y": 3.5, "width": 1, "depth": 1}]})
    assert not applies(with_obstacle, make_domain(with_obstacle))
    many = Problem.model_validate({
        "boundary": [[0, 0], [40, 0], [40, 10], [0, 10]],
        "rooms": [{"id": f"r{k}", "target_size": [3, 3]}
                  for k in range(MAX_TILED_ROOMS + 1)]})
    assert not applies(many, make_domain(many))
    assert guillotine_layout(many, make_domain(many), seed=0) is None


@pytest.mark.parametrize(("column", "strip"), [("east", "north"), ("east", "south"),
                                             ("west", "north"), ("west", "south")])
def test_the_halves_of_a_tilings_cuts_are_swapped_to_meet_the_walls(column: str,
                                                                    strip: str) -> None:
    # Which side each stands on is the halves of its cut; with a single annealing step,
    # the swaps of halves alone must put them on their walls.
    problem = column_strip_room(column, strip)
    found = guillotine_layout(problem, make_domain(problem), seed=0, steps=1,
                              accept=lambda rooms: check_layout(problem, rooms).valid)
    assert found is not None
    placed = found.rooms["column"][0]
    assert placed.x0 == pytest.approx(4 if column == "east" else 0)
    placed = found.rooms["strip"][0]
    assert placed.y0 == pytest.approx(2.5 if strip == "north" else 0)


def test_the_polish_sets_the_areas_the_annealing_left_a_few_per_cent_off() -> None:
    problem = column_strip_room("west", "north")
    domain = make_domain(problem)
    brief = make_brief(problem, domain)
    # The one tiling (column | room / strip), each room asking a few per cent off.
    state = State([0, 2, 1, HORIZONTAL, VERTICAL], [1.06, 0.95, 1.04],
                              [0.5] * 3)
    energy, broken = score.score_state(brief, state)
    assert broken == 0
    assert layout_objective(problem, domain, tree.layout_of(brief, state)) > 0.01
    polished, lower = anneal.polished(brief, state, energy, None)
    assert lower < energy
    rooms = tree.layout_of(brief, polished)
    assert check_layout(problem, rooms).valid
    assert layout_objective(problem, domain, rooms) < 1e-6


def column_strip_room(column: str, strip: str) -> Problem:
    """The one tiling of a 6 x 4 m floor: a 2 x 4 column on the `column` wall beside a
    4 x 1.5 strip on the `strip` wall, over or under a 4 x 2.5 room."""
    return Problem.model_validate({
        "boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
        "rooms": [
            {"id": "column", "type": "bedroom", "target_size": [2, 4], "min_size": [1.8, 3.6],
             "max_size": [2.2, 4.4], "boundary": [column]},
            {"id": "strip", "type": "corridor", "target_size": [4, 1.5],
             "min_size": [3.6, 1.4], "max_size": [4.4, 1.6], "boundary": [strip]},
            {"id": "room", "type": "bedroom", "target_size": [4, 2.5], "min_size": [3.6, 2.3],
             "max_size": [4.4, 2.7]},
        ],
    })


def notch_sliver_brief() -> Problem:
    """An 8 x 6 m box less its north-east 3 x 2 m, cut as a plan drawn on the box: the
    east room's cell (4 x 4.05) crosses the notch's corner by 5 cm, so cut to the outline
    it keeps a 1 m x 5 cm strip beside the notch, and its box is still its target."""
    return Problem.model_validate({
        "boundary": [[0, 0], [8, 0], [8, 4], [5, 4], [5, 6], [0, 6]],
        "rooms": [
            {"id": "south", "type": "bedroom", "target_size": [4, 3], "min_size": [3, 2.5],
             "max_size": [5, 3.5], "boundary": ["south", "west"]},
            {"id": "west", "type": "bedroom", "target_size": [4, 3], "min_size": [3, 2.5],
             "max_size": [5, 3.5], "boundary": ["north", "west"]},
            {"id": "east", "type": "living", "target_size": [4, 4.05], "min_size": [3, 3],
             "max_size": [5, 5], "boundary": ["east"]},
            {"id": "store", "type": "storage", "target_size": [1, 1.95], "min_size": [0.8, 1.5],
             "max_size": [1.5, 2.5]},
        ],
    })


def test_a_strip_the_outline_cuts_off_a_room_may_be_thinner_than_an_arm() -> None:
    problem = notch_sliver_brief()
    found = guillotine_layout(problem, make_domain(problem), seed=0,
                              accept=lambda rooms: check_layout(problem, rooms).valid)
    assert found is not None
    east = found.rooms["east"]
    xs = [v for b in east for v in (b.x0, b.x1)]
    ys = [v for b in east for v in (b.y0, b.y1)]
    # Its box at the target, so its strip beside the notch is there, 5 cm thin.
    assert (max(xs) - min(xs), max(ys) - min(ys)) == (pytest.approx(4), pytest.approx(4.05))
    assert min(min(b.x1 - b.x0, b.y1 - b.y0) for b in east) == pytest.approx(0.05)
    assert layout_objective(problem, make_domain(problem), found.rooms) < 0.01


def test_an_arm_the_search_made_thinner_than_half_a_metre_is_broken() -> None:
    problem = notch_sliver_brief()
    domain = make_domain(problem)
    plan = boxed_models(make_brief(problem, domain), domain)[1]
    south, west, store = (0, 0, 4, 3), (0, 3, 4, 6), (4, 4.05, 5, 6)
    # The east room as the plan has it: a 4 x 4.05 cell cut by the outline.
    cell = (4, 0, 8, 4.05)
    rooms = [[south], [west], tree.clipped([cell], plan.outside), [store]]
    _, broken = score.score_layout(plan, rooms, [[south], [west], [cell], [store]])
    assert broken == 0
    # The same floor as two parts the tree made, one of them 5 cm thin.
    made = [(4, 0, 8, 4), (4, 4, 5, 4.05)]
    _, broken = score.score_layout(plan, [[south], [west], made, [store]],
                                  [[south], [west], made, [store]])
    assert broken == 1


def test_a_part_beside_a_void_may_be_as_thin_as_the_notch_leaves_it() -> None:
    # The same plan on the box with the notch as a void (no room cut, so the east room is
    # an L the tree made): its 5 cm strip touching the void is how the notch leaves it
    # (a planted plan's bedroom steps 0.3 m over a notch's corner); as thin away from the
    # void, broken.
    problem = notch_sliver_brief()
    domain = make_domain(problem)
    plan = boxed_models(make_brief(problem, domain), domain)[0]
    assert plan.voids == ((5, 4, 8, 6),) and not plan.outside
    south, west, store = (0, 0, 4, 3), (0, 3, 4, 6), (4, 4.05, 5, 6)
    for strip, broken in (((4, 4, 5, 4.05), 0), ((4, 4, 4.9, 4.05), 1)):
        east = [(4, 0, 8, 4), strip]
        rooms = [[south], [west], east, [store], [plan.voids[0]]]
        assert score.score_layout(plan, rooms, rooms)[1] == broken


def test_a_strip_the_outline_cut_meets_the_rest_of_its_room_over_its_own_width() -> None:
    # A 4 x 4 m box less its south-west 3.8 x 2 m: a hall drawn on the whole box keeps,
    # cut to the outline, its north half and a 20 cm strip down the east wall, which
    # meets the half over its 20 cm width.
    problem = Problem.model_validate({
        "boundary": [[3.8, 0], [4, 0], [4, 4], [0, 4], [0, 2], [3.8, 2]],
        "rooms": [{"id": "hall", "type": "hall", "target_size": [4, 4], "min_size": [3, 3],
                   "max_size": [4, 4]}],
    })
    domain = make_domain(problem)
    plan = boxed_models(make_brief(problem, domain), domain)[1]
    cell = (0, 0, 4, 4)
    hall = tree.clipped([cell], plan.outside)
    assert min(min(r[2] - r[0], r[3] - r[1]) for r in hall) == pytest.approx(0.2)
    _, broken = score.score_layout(plan, [hall], [[cell]])
    assert broken == 0
