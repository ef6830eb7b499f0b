"""Planted briefs (bench/planted.py): every drawn plan meets its own brief, and the
report's measures (bench/planted_report.py). Nothing here solves."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.planted import brief_json, draw, load, main
from bench.planted_report import (
    area_error,
    markdown,
    measure_plan,
    medians,
    parse_seeds,
    summarise,
)
from floorplan.models import Problem
from floorplan.solver import check_layout
from tests.paths import PLANTED, PLANTED_COMPLEX

SEEDS = range(20)


def assert_plan_meets_brief(problem: Problem, truth_rooms: dict) -> None:
    check = check_layout(problem, truth_rooms)
    failed = [(c.kind, c.rooms, c.detail) for c in check.constraints
              if not c.satisfied and not c.soft]
    assert check.valid and not failed, failed
    assert check.coverage >= 0.999
    assert sum(check.size_error.values()) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("seed", SEEDS)
def test_drawn_plan_meets_its_brief(seed: int) -> None:
    problem, truth = draw(seed)
    assert Problem.model_validate(brief_json(problem)) == problem
    assert {r.id for r in problem.rooms} == {r.id for r in truth.rooms}
    assert 5 <= len(problem.rooms) <= 14
    assert_plan_meets_brief(problem, truth.boxes())
    assert any(len(r.polygon) > 4 for r in truth.rooms), "no L or T room"
    # Doors: a spanning tree (rooms - 1 adjacencies) and one guide point at the entrance.
    assert len(problem.adjacency) == len(problem.rooms) - 1
    assert problem.entrance is not None
    assert sum(len(r.positions) for r in problem.rooms) == 1


def test_plans_are_cut_from_their_bounding_box_to_the_outline() -> None:
    # As bench/data/planted was drawn: a cell across the outline keeps its inside,
    # so some plans have more L rooms than merged pairs (at most two), and some rooms
    # cross the lines between the outline's own rectangles.
    shaped = []
    for seed in SEEDS:
        _, truth = draw(seed)
        shaped.append(sum(len(r.shape.simplify(0).exterior.coords) > 5 for r in truth.rooms))
    assert max(shaped) > 2


def test_same_seed_same_brief() -> None:
    for seed in (3, 2001):
        (p1, t1), (p2, t2) = draw(seed), draw(seed)
        assert brief_json(p1) == brief_json(p2) and t1 == t2
    assert brief_json(draw(3)[0]) != brief_json(draw(4)[0])


def test_room_count_is_honoured() -> None:
    for rooms in (5, 9, 14):
        problem, truth = draw(100 + rooms, rooms)
        assert len(problem.rooms) == len(truth.rooms) == rooms
        assert_plan_meets_brief(problem, truth.boxes())


def test_cli_writes_what_load_reads(tmp_path: Path) -> None:
    assert main(["--seed", "7", "--rooms", "8", "--out", str(tmp_path)]) == 0
    problem, truth = load(tmp_path / "planted-08-7.json")
    drawn, planted = draw(7, 8)
    assert brief_json(problem) == brief_json(drawn) and truth == planted


@pytest.mark.parametrize("folder", [PLANTED, PLANTED_COMPLEX], ids=lambda p: p.name)
def test_the_committed_briefs_load_and_their_plans_are_valid(folder: Path) -> None:
    paths = sorted(folder.glob("*.truth.json"))
    assert len(paths) == 24
    for path in paths:
        problem, truth = load(path)
        assert_plan_meets_brief(problem, truth.boxes())
        # Written back, the files are as they were.
        brief = json.loads(path.with_name(path.name.replace(".truth", "")).read_text())
        assert brief_json(problem) == brief
        assert truth.to_json() == json.loads(path.read_text())


def test_plan_measures() -> None:
    problem, truth = draw(11)
    plan = measure_plan(problem, truth)
    assert plan["valid"] and plan["coverage"] == pytest.approx(1.0)
    assert plan["objective"] == pytest.approx(0.0, abs=1e-6)
    # Only the L and T rooms are below their bounding boxes' areas.
    assert 0 < plan["area_error"] < 0.2
    assert area_error(problem, {}) is None


def test_parse_seeds() -> None:
    assert parse_seeds("2001-2003,2010") == [2001, 2002, 2003, 2010]
    assert parse_seeds("") == []


def test_summary_and_table_of_fabricated_rows() -> None:
    def run(valid: bool, error: float | None) -> dict:
        return {"valid": valid, "coverage": 1.0 if error is not None else None,
                "area_error": error, "objective": 1.0 if error is not None else None}

    rows = [{"name": "a", "rooms": 5, "plan": run(True, 0.1), "ours": run(True, 0.15),
             "flat": run(False, 0.12)},
            {"name": "b", "rooms": 6, "plan": run(True, 0.05), "ours": run(True, 0.2),
             "flat": run(False, None)}]
    summary = summarise(rows)
    assert summary["ours"]["within_2x"] == 1 and summary["flat"]["within_2x"] == 0
    assert summary["ours"]["median_area_error"] == pytest.approx(0.175)
    assert summary["flat"]["valid"] == 0 and summary["flat"]["with_layout"] == 1
    text = markdown({"machine": {"date": "d", "commit": "c"}, "settings": {"flat_limit": 10},
                     "briefs": rows, "summary": summary})
    assert "| a | 5 | yes / yes / no |" in text and "| ours | 2 | 2 | 2 |" in text


def test_repeated_runs_give_their_medians() -> None:
    def run(valid: bool, coverage: float | None, error: float | None) -> dict:
        return {"valid": valid, "coverage": coverage, "area_error": error,
                "objective": error, "first_valid": 1.0 if valid else None,
                "hard_violations": 0, "seconds": 5.0, "time_limit": 5.0, "status": "ok"}

    # One run of three without a layout: the row is the other two's median, and valid.
    row = medians([run(True, 1.0, 0.05), run(False, None, None), run(True, 0.995, 0.08)])
    assert row["valid"] and row["coverage"] == 0.995 and row["area_error"] == 0.08
    assert len(row["runs"]) == 3 and row["first_valid"] == 1.0
    # Two of three invalid: the brief counts as invalid.
    row = medians([run(False, 0.97, 0.05), run(False, 0.96, 0.04), run(True, 1.0, 0.1)])
    assert not row["valid"] and row["coverage"] == 0.97
    # Most runs without a layout: the brief has none.
    row = medians([run(False, None, None), run(False, None, None), run(True, 1.0, 0.1)])
    assert row["coverage"] is None and row["area_error"] is None and not row["valid"]
    assert medians([run(True, 1.0, 0.05)]) == run(True, 1.0, 0.05)
