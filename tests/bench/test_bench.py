"""The benchmark harness end to end on a tiny problem: all three solvers, one run."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from bench.cli import main
from bench.evaluate import RunRecord
from bench.report import build_results, complexity, markdown
from floorplan.models import Problem

TINY = {
    "name": "tiny-3",
    "boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
    "rooms": [
        {"id": "a", "min_size": [1.5, 1.5], "max_size": [4, 4], "target_size": [3, 4],
         "boundary": ["west"]},
        {"id": "b", "min_size": [1.5, 1.5], "max_size": [4, 4], "target_size": [3, 2]},
        {"id": "c", "min_size": [1.5, 1.5], "max_size": [4, 4], "target_size": [3, 2],
         "aspect_ratio": [1, 2]},
    ],
    "adjacency": [{"a": "a", "b": "b", "min_contact": 1.0}],
    "options": {"time_limit": 1},
}


@pytest.fixture
def cases(tmp_path: Path) -> Path:
    directory = tmp_path / "cases"
    directory.mkdir()
    (directory / "tiny-3.json").write_text(json.dumps(TINY))
    return directory


@pytest.mark.slow
def test_harness_writes_every_output_with_every_field(cases: Path, tmp_path: Path) -> None:
    out = tmp_path / "results"
    code = main(["--cases", str(cases), "--repeat", "1", "--out", str(out),
                 "--solvers", "ours,ours-long,flat,anneal", "--flat-limit", "1", "--quiet"])
    assert code == 0
    for name in ("results.json", "results.md"):
        assert (out / name).stat().st_size > 0, name
    if importlib.util.find_spec("matplotlib") is not None:  # the optional `bench` extra
        assert (out / "complexity.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    results = json.loads((out / "results.json").read_text())
    assert {"cpu", "cores", "python", "pyscipopt", "scip", "date"} <= set(results["machine"])
    runs = results["runs"]
    assert sorted(r["solver"] for r in runs) == ["anneal", "flat", "ours", "ours-long"]
    for run in runs:
        for key in ("first_valid", "first_pass", "final_time", "coverage", "hard_violations",
                    "size_error", "objective"):
            assert key in run, key
        assert run["final_time"] <= run["time_limit"] + 2.0
    ours = next(r for r in runs if r["solver"] == "ours")
    # Ours lays out three rooms in a rectangle completely and validly within its second.
    assert ours["first_valid"] is not None and ours["hard_violations"] == 0
    assert ours["coverage"] >= 0.99
    summary = results["summary"]["tiny-3"]
    assert summary["complexity"] == 3 + (3 + 3 + 1 + 0 + 1 + 1)
    assert set(summary["solvers"]) == {"ours", "ours-long", "flat", "anneal"}
    # ours-long has the baselines' limit, here capped at 1 s.
    assert {r["time_limit"] for r in runs if r["solver"] in ("ours-long", "flat")} == {1.0}
    table = (out / "results.md").read_text()
    assert "| tiny-3 | 3 |" in table and "Speed-up" in table
    # The tables can be rewritten from the raw runs alone, as they were.
    (out / "results.md").unlink()
    assert main(["--report-only", "--cases", str(cases), "--out", str(out)]) == 0
    assert (out / "results.md").read_text() == table


def test_report_only_names_a_missing_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                         ) -> None:
    assert main(["--report-only", "--out", str(tmp_path)]) == 2
    assert "results.json" in capsys.readouterr().err


def test_complexity_counts_constraints_as_table_1_does() -> None:
    counts = complexity(Problem.model_validate(TINY))
    assert counts == {"size": 3, "overlap": 3, "ratio": 1, "pos": 0, "boundary": 1,
                      "adjacency": 1, "total": 9, "rooms": 3, "complexity": 12}


def test_aisles_count_as_covered_floor_and_are_checked() -> None:
    # Two rooms with a 1.8 m aisle between them: covered only with the aisle, and an
    # aisle overlapping a room is a hard violation, as in the solver's own report.
    from shapely.geometry import box

    from bench.evaluate import evaluate
    from bench.solvers import Trace
    from floorplan.solver.geometry import Box, make_domain

    problem = Problem.model_validate({
        "boundary": [[0, 0], [10, 0], [10, 4], [0, 4]],
        "rooms": [{"id": "a", "min_size": [2, 2]}, {"id": "b", "min_size": [2, 2]}]})
    rooms = {"a": [Box(0, 0, 4.1, 4)], "b": [Box(5.9, 0, 10, 4)]}
    domain = make_domain(problem)

    def run(aisles: list) -> dict:  # type: ignore[type-arg]
        trace = Trace("ours", 5.0, layouts=[(0.1, rooms)], final=rooms, seconds=0.2,
                      aisles=aisles, regions={"left": ["a"], "right": ["b"]} if aisles else {})
        return evaluate(problem, domain, trace, case="c", repeat=0, seed=0).to_json()

    bare = run([])
    assert bare["coverage"] < 0.99 and bare["first_valid"] is None
    aisle = run([box(4.1, 0, 5.9, 4)])
    assert aisle["coverage"] >= 0.999 and aisle["valid"] and aisle["hard_violations"] == 0
    assert aisle["first_valid"] == 0.1
    overlapping = run([box(3.9, 0, 5.9, 4)])
    assert overlapping["hard_violations"] >= 1 and not overlapping["valid"]


def record(repeat: int, objective: float, coverage: float) -> RunRecord:
    return RunRecord(case="tiny-3", solver="ours", repeat=repeat, seed=repeat, time_limit=1.0,
                     status="done", first_valid=0.1, first_pass=0.1, final_time=1.0,
                     last_improvement=0.9, coverage=coverage, hard_violations=0,
                     size_error=objective, objective=objective, valid=True,
                     layouts_recorded=1, layouts_checked=1, extra={})


def test_results_give_the_spread_of_the_runs_beside_the_median() -> None:
    problem = Problem.model_validate(TINY)
    records = [record(0, 12.0, 0.995), record(1, 10.0, 1.0), record(2, 30.0, 1.0)]
    results = build_results({"tiny-3": problem}, records, settings={},
                            machine={"date": "-", "cpu": "-", "cores": 2, "python": "-",
                                     "pyscipopt": "-", "scip": "-"})
    ours = results["summary"]["tiny-3"]["solvers"]["ours"]
    assert ours["objective"] == 12.0 and ours["objective_range"] == [10.0, 30.0]
    assert ours["coverage_range"] == [0.995, 1.0]
    table = markdown(results)
    assert "| 12.0 (10.0-30.0) | 12.0 (10.0-30.0) |" in table
    assert "100.0 % (99.5-100.0) %" not in table and "100.0 (99.5-100.0) %" in table
    # Without the flat baseline there is no comparison to make.
    assert "Speed-up" not in table and "Quality against the flat baseline" not in table


@pytest.mark.slow
def test_bench_batch_measures_ours_and_the_annealer_on_the_same_brief(tmp_path: Path) -> None:
    from bench.batch import main as batch_main

    brief = tmp_path / "tiny.json"
    brief.write_text(json.dumps({
        "name": "tiny", "boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
        "rooms": [{"id": "a", "type": "living", "min_size": [2, 2], "target_size": [3, 4]},
                  {"id": "b", "type": "bedroom", "min_size": [2, 2], "target_size": [3, 4]}],
        "options": {"time_limit": 1}}))
    out = tmp_path / "rows.json"
    assert batch_main([str(brief), "--count", "5", "--processes", "2", "--out", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert [r["solver"] for r in rows] == ["ours", "anneal"]
    assert all(r["layouts"] == 5 and r["per_second"] > 0 for r in rows)
    assert rows[0]["good"] == 1.0 and 0 < rows[0]["distinct"] <= 1
    assert rows[0]["eq12_median"] is not None and rows[1]["eq12_median"] is not None
    from bench.batch import table

    assert table(rows).splitlines()[2].startswith("| tiny | 2 | 1 |")


@pytest.mark.slow
def test_the_api_round_trip_bench_times_a_real_server(cases: Path, tmp_path: Path) -> None:
    from bench.api import main as api_main

    out = tmp_path / "api"
    assert api_main(["--cases", str(cases / "tiny-3.json"), "--repeat", "2", "--pause", "0",
                     "--out", str(out)]) == 0
    results = json.loads((out / "results.json").read_text())
    assert [t["seed"] for t in results["trips"]] == [0, 1]
    assert all(t["status"] == "succeeded" and t["valid"] for t in results["trips"])
    # The round trip holds the solve: its clock runs from the POST to the job's end.
    assert all(t["seconds"] >= t["solve_time"] > 0 for t in results["trips"])
    (row,) = results["summary"]
    assert row["case"] == "tiny-3" and row["runs"] == 2
    assert "| tiny-3 |" in (out / "results.md").read_text()
