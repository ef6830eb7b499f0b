"""Quality against time (bench/anytime.py): the profile each run records, and the
picture per case drawn from it, with matplotlib and without."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from typing import Any

import pytest

from bench import cli, report
from bench.anytime import PICTURE, profile_series, reached
from bench.cli import main

CASES = Path(__file__).resolve().parents[2] / "bench" / "data" / "cases"
HAS_MATPLOTLIB = importlib.util.find_spec("matplotlib") is not None


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One real run, apartment-5 at a 1.5 s limit, ours and flat (capped at 2 s): a few
    seconds."""
    cases = tmp_path_factory.mktemp("cases")
    brief = json.loads((CASES / "apartment-5.json").read_text(encoding="utf-8"))
    brief["options"] = {**(brief.get("options") or {}), "time_limit": 1.5}
    (cases / "apartment-5.json").write_text(json.dumps(brief), encoding="utf-8")
    out = tmp_path_factory.mktemp("results")
    code = main(["--cases", str(cases), "--repeat", "1", "--out", str(out),
                 "--solvers", "ours,flat", "--flat-limit", "2", "--quiet"])
    assert code == 0
    return out


def test_each_run_records_a_profile_in_time_order_ending_at_its_final_layout(run: Path
                                                                             ) -> None:
    results = json.loads((run / "results.json").read_text())
    runs = {r["solver"]: r for r in results["runs"]}
    assert set(runs) == {"ours", "flat"}
    plotted = {s.solver: s for s in profile_series(results, "apartment-5")}
    for solver, r in runs.items():
        assert r["final_time"] > 0 and r["objective"] is not None, solver
        s = plotted[solver]  # the points the picture draws
        assert s.times == [p[0] for p in r["profile"]]
        assert all(a <= b for a, b in zip(s.times, s.times[1:], strict=False)), solver
        assert s.times[0] >= 0 and s.times[-1] == r["final_time"]
        assert s.objective[-1] == r["objective"] and s.coverage[-1] == r["coverage"]
        assert all(e >= 0 and 0 <= c <= 1 + 1e-9 for e, c in zip(s.objective, s.coverage,
                                                                  strict=True))
        assert s.times[0] <= s.reached_final <= s.times[-1]
    # Ours has a first layout long before its limit.
    assert plotted["ours"].times[0] < 1.5


@pytest.mark.skipif(not HAS_MATPLOTLIB, reason="matplotlib (the bench extra) not installed")
def test_a_picture_per_case_linked_from_results_md_and_redrawn_from_results_json(
        run: Path) -> None:
    from matplotlib import image

    png = run / PICTURE.format(case="apartment-5")
    pixels = image.imread(png)
    assert pixels.shape[0] > 200 and pixels.shape[1] > 200
    assert float(pixels.std()) > 0  # not a blank image
    table = (run / "results.md").read_text()
    assert "## Quality against time" in table
    assert "[apartment-5](profile-apartment-5.png) | ours | 1.5 | 1 |" in table
    png.unlink()
    assert main(["--profile-only", "--out", str(run)]) == 0
    assert image.imread(png).shape == pixels.shape
    assert (run / "results.md").read_text() == table


def test_without_matplotlib_the_outputs_are_written_and_the_pictures_skipped(
        run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    results = json.loads((run / "results.json").read_text())
    monkeypatch.setattr(report, "has_matplotlib", lambda: False)
    monkeypatch.setattr(cli, "has_matplotlib", lambda: False)
    report.write_outputs(results, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.json", "results.md"]
    table = (tmp_path / "results.md").read_text()
    assert "pictures were not drawn" in table and "(profile-" not in table
    assert "no profile-<case>.png" in capsys.readouterr().err
    assert main(["--profile-only", "--out", str(tmp_path)]) == 1
    assert "matplotlib is not installed" in capsys.readouterr().err


def test_profile_only_names_a_missing_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                          ) -> None:
    assert main(["--profile-only", "--out", str(tmp_path)]) == 2
    assert "results.json" in capsys.readouterr().err


def test_final_quality_is_reached_when_the_values_stay_near_the_last() -> None:
    times = [0.1, 0.5, 1.0, 2.0, 3.0]
    assert reached(times, [40.0, 10.0, 5.02, 5.0, 5.0]) == 1.0  # 5.02 is within 1 %
    assert reached(times, [40.0, 10.0, 6.0, 5.0, 5.0]) == 2.0
    assert reached(times, [4.0, 10.0, 5.0, 5.0, 5.0]) == 1.0  # worse in between
    assert reached([0.2], [7.0]) == 0.2


@pytest.mark.skipif(not HAS_MATPLOTLIB, reason="matplotlib (the bench extra) not installed")
def test_a_run_without_any_layout_is_drawn_where_it_ended(tmp_path: Path) -> None:
    from bench.anytime import plot_profiles

    def run(solver: str, profile: list[list[float]], final_time: float) -> dict[str, Any]:
        return {"case": "c", "solver": solver, "repeat": 0, "time_limit": final_time,
                "final_time": final_time, "first_valid": profile[0][0] if profile else None,
                "valid": bool(profile), "profile": profile}

    results = {"summary": {"c": {"rooms": 140}},
               "runs": [run("ours", [[0.5, 900.0, 0.4], [3.0, 80.0, 1.0]], 3.0),
                        run("flat", [], 61.8)],
               "machine": {"date": "2026-11-29", "cores": 2, "load_average": [5.9]}}
    assert [p.name for p in plot_profiles(results, tmp_path)] == ["profile-c.png"]
    assert [s.solver for s in profile_series(results, "c")] == ["ours"]


def test_results_md_warns_when_the_machine_was_busy() -> None:
    from bench.report import _load_note

    assert "busy" in _load_note({"load_average": [5.86, 5.6, 3.9], "cores": 2})
    assert _load_note({"load_average": [1.2, 1.0, 1.0], "cores": 2}) == ""
    assert _load_note({}) == ""
