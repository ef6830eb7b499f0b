"""Different plans from different seeds (options.diverse, issue 23), on real SCIP; and
programmes drawn from a template (models.programme)."""

from __future__ import annotations

import json

from models import Problem
from models.programme import vary_programme
from solver import solve
from solver.distinct import count_distinct
from tests.paths import ROOT

APARTMENT = json.loads((ROOT / "examples/apartment-5.json").read_text())
FLAT_7 = json.loads((ROOT / "examples/flat-7-template.json").read_text())


def test_diverse_seeds_break_ties_differently() -> None:
    from solver.distinct import DistinctPlans

    problem = Problem.model_validate(APARTMENT)
    layouts = [solve(problem.with_options(seed=seed, time_limit=1.5, diverse=True))
               for seed in range(6)]
    assert all(layout.report.valid for layout in layouts)
    exact = DistinctPlans(share=0.0)  # any cell of the 10 cm grid differing
    for layout in layouts:
        exact.add(layout)
    assert exact.plans >= 3


def test_drawn_sizes_give_distinct_valid_plans() -> None:
    from models.programme import vary_sizes

    problem = Problem.model_validate(APARTMENT)
    layouts = [solve(vary_sizes(problem, seed).with_options(seed=seed, time_limit=3,
                                                            diverse=True))
               for seed in range(6)]
    assert all(layout.report.valid for layout in layouts)
    plans, _ = count_distinct(layouts)  # at most 5 % of the floor alike
    assert plans >= 3, [layout.report.objective for layout in layouts]


def test_the_pull_is_drawn_from_the_seed() -> None:
    problem = Problem.model_validate(APARTMENT)
    one, again = (solve(problem.with_options(seed=4, time_limit=1.5, diverse=True))
                  for _ in range(2))
    assert count_distinct([one, again])[0] in (1, 2)  # same draw; timing may differ
    assert one.report.valid and again.report.valid


def test_drawn_programmes_differ_in_rooms_and_sizes_within_the_template() -> None:
    plain = Problem.model_validate(FLAT_7)
    drawn = [vary_programme(FLAT_7, seed) for seed in range(12)]
    assert len({len(p.rooms) for p in drawn}) >= 2
    assert len({tuple(r.target_size for r in p.rooms) for p in drawn}) == 12
    for p in drawn:
        for room in p.rooms:
            assert room.min_size is not None and room.max_size is not None
            assert room.target_size is not None
            assert all(room.min_size[a] <= room.target_size[a] <= room.max_size[a]
                       for a in (0, 1))
        assert {r.type for r in plain.rooms} >= {r.type for r in p.rooms} - {"bathroom"}


def test_a_drawn_programme_is_laid_out_validly() -> None:
    problem = vary_programme(FLAT_7, 3).with_options(seed=3, time_limit=3, diverse=True)
    layout = solve(problem)
    assert layout.report.valid
    assert {r.id for r in layout.rooms} == {r.id for r in problem.rooms}


def test_good_enough_stops_at_the_first_good_layout() -> None:
    from solver.stopping import GoodEnough

    problem = Problem.model_validate(APARTMENT).with_options(seed=2, time_limit=4,
                                                            diverse=True)
    good = GoodEnough(problem, bound=1e9)
    layout = solve(problem, on_event=good, should_stop=lambda: good.reached)
    assert good.reached
    assert layout.report.valid and layout.report.coverage >= 0.99
    assert layout.report.termination.value == "interrupted"
    never = GoodEnough(problem, bound=0.0)  # Eq. 12 is never 0 here: the solve runs on
    full = solve(problem, on_event=never, should_stop=lambda: never.reached)
    assert not never.reached and full.report.termination.value != "interrupted"
    assert full.report.objective <= layout.report.objective + 1e-6


def test_drawn_sizes_stay_within_each_rooms_bounds() -> None:
    from models.programme import vary_sizes

    problem = Problem.model_validate(APARTMENT)
    drawn = [vary_sizes(problem, seed) for seed in range(10)]
    assert len({tuple(r.target_size for r in p.rooms) for p in drawn}) == 10
    for p in drawn:
        assert [r.id for r in p.rooms] == [r.id for r in problem.rooms]
        for room in p.rooms:
            assert room.min_size is not None and room.max_size is not None
            assert room.target_size is not None
            assert all(room.min_size[a] <= room.target_size[a] <= room.max_size[a]
                       for a in (0, 1))
