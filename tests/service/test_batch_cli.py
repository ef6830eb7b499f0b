"""`floorplan batch` (issue 23), run for real in subprocesses: files and summary, skip
and resume, Ctrl-C; and its warm pool, with real crashing and hanging workers."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from floorplan.service.cli.exits import EXIT_INTERRUPTED, EXIT_OK
from floorplan.service.cli.pool import WarmPool
from tests.service.test_cli import TINY, _env, floorplan, write_problem


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


@pytest.mark.slow
def test_batch_writes_a_file_per_layout_and_the_summaries(tmp_path: Path) -> None:
    brief = write_problem(tmp_path, TINY, "tiny.json")
    done = floorplan("batch", brief, "--count", "4", "--out", "out", "--processes", "2",
                     "--seed", "7", "--time-limit", "1", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    out = tmp_path / "out"
    assert sorted(p.name for p in out.glob("tiny-*.json")) == [
        f"tiny-{s:06d}.json" for s in range(7, 11)]
    summary = _summary(out)
    assert summary["layouts"] == 4 and summary["failed"] == 0
    assert summary["valid"] == 4
    assert 1 <= summary["distinct_plans"] <= 4
    assert [r["seed"] for r in summary["rows"]] == [7, 8, 9, 10]
    with (out / "summary.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [int(r["seed"]) for r in rows] == [7, 8, 9, 10]
    assert all(r["valid"] == "True" and float(r["coverage"]) >= 0.99 for r in rows)
    assert all(float(r["objective"]) >= 0 and float(r["time"]) > 0 for r in rows)
    assert "4 of 4 layouts (0 done before), 4 valid, 0 failed" in done.stderr


@pytest.mark.slow
def test_batch_svg_format(tmp_path: Path) -> None:
    brief = write_problem(tmp_path, TINY, "tiny.json")
    done = floorplan("batch", brief, "-n", "1", "-o", "out", "--format", "svg",
                     "--time-limit", "1", "-q", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    assert (tmp_path / "out/tiny-000000.svg").read_text().lstrip().startswith("<")
    assert done.stderr == ""


@pytest.mark.slow
def test_rerun_skips_what_is_done_and_goes_on(tmp_path: Path) -> None:
    brief = write_problem(tmp_path, TINY, "tiny.json")
    first = floorplan("batch", brief, "-n", "2", "-o", "out", "--time-limit", "1",
                      cwd=tmp_path)
    assert first.returncode == EXIT_OK, first.stderr
    out = tmp_path / "out"
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("tiny-*.json")}
    (out / "tiny-000001.json").unlink()  # lost: to be done again
    again = floorplan("batch", brief, "-n", "3", "-o", "out", "--time-limit", "1",
                      cwd=tmp_path)
    assert again.returncode == EXIT_OK, again.stderr
    assert "3 of 3 layouts (1 done before)" in again.stderr
    assert (out / "tiny-000000.json").stat().st_mtime_ns == stamps["tiny-000000.json"]
    assert (out / "tiny-000001.json").exists() and (out / "tiny-000002.json").exists()
    summary = _summary(out)
    assert summary["layouts"] == 3 and [r["seed"] for r in summary["rows"]] == [0, 1, 2]


@pytest.mark.slow
def test_ctrl_c_stops_and_keeps_what_is_done(tmp_path: Path) -> None:
    brief = write_problem(tmp_path, TINY, "tiny.json")
    proc = subprocess.Popen(
        [sys.executable, "-m", "floorplan.service", "batch", str(brief), "-n", "500", "-o", "out",
         "--time-limit", "1", "--processes", "2"],
        cwd=tmp_path, env=_env(), stderr=subprocess.PIPE, text=True)
    out = tmp_path / "out"
    deadline = time.monotonic() + 60
    while len(list(out.glob("tiny-*.json"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == EXIT_INTERRUPTED, stderr
    summary = _summary(out)
    assert 2 <= summary["layouts"] < 500
    assert all((out / r["file"]).exists() for r in summary["rows"])
    assert "interrupted" in stderr


#: One room filling its floor: every seed gives the same plan.
ONE_PLAN: dict = {
    "name": "one", "boundary": [[0, 0], [4, 0], [4, 3], [0, 3]],
    "rooms": [{"id": "studio", "type": "living", "min_size": [4, 3], "max_size": [4, 3],
               "target_size": [4, 3]}],
}


@pytest.mark.slow
def test_a_plan_the_batch_holds_is_drawn_again_by_default_and_the_first_kept(
        tmp_path: Path) -> None:
    brief = write_problem(tmp_path, ONE_PLAN, "one.json")
    done = floorplan("batch", brief, "-n", "3", "-o", "out", "--time-limit",
                     "1", "--processes", "2", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    out = tmp_path / "out"
    summary = _summary(out)
    # Layouts 2 and 3 repeat the first plan: each is drawn twice more, in vain, and
    # keeps its first layout.
    assert summary["valid"] == 3 and summary["distinct_plans"] == 1
    assert summary["redraws"] == 4
    assert [(r["seed"], r["draw"]) for r in summary["rows"]] == [(0, 0), (1, 0), (2, 0)]
    assert sorted(p.name for p in out.iterdir() if p.suffix == ".json") == [
        "one-000000.json", "one-000001.json", "one-000002.json", "summary.json"]
    assert "4 solves redrawn for new plans" in done.stderr
    with (out / "summary.csv").open() as f:
        assert [r["draw"] for r in csv.DictReader(f)] == ["0", "0", "0"]
    again = floorplan("batch", brief, "-n", "3", "-o", "out", "--distinct", "-q",
                      cwd=tmp_path)
    assert again.returncode == EXIT_OK and _summary(out)["layouts"] == 3
    one_draw = floorplan("batch", brief, "-n", "2", "-o", "out1", "--draws",
                         "1", "--time-limit", "1", "-q", cwd=tmp_path)
    assert one_draw.returncode == EXIT_OK and _summary(tmp_path / "out1")["redraws"] == 1
    kept = floorplan("batch", brief, "-n", "2", "-o", "out3", "--no-distinct",
                     "--time-limit", "1", "-q", cwd=tmp_path)
    assert kept.returncode == EXIT_OK and _summary(tmp_path / "out3")["redraws"] == 0
    alone = floorplan("batch", brief, "-n", "2", "-o", "out2", "--draws", "1", "--no-distinct",
                      cwd=tmp_path)
    assert alone.returncode == 2 and "--draws: not with --no-distinct" in alone.stderr


@pytest.mark.slow
def test_distinct_keeps_a_draw_with_a_new_plan_in_the_layout_s_file(tmp_path: Path) -> None:
    brief = write_problem(tmp_path, TINY, "tiny.json")
    done = floorplan("batch", brief, "-n", "6", "-o", "out", "--distinct", "--time-limit",
                     "1", "-q", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    out = tmp_path / "out"
    rows = _summary(out)["rows"]
    assert len(rows) == 6 and all(r["valid"] for r in rows)
    assert not list(out.glob(".*.draw*"))
    for row in rows:  # every file holds the layout its row describes
        layout = json.loads((out / row["file"]).read_text())
        assert layout["report"]["objective"] == pytest.approx(row["objective"], abs=1e-5)


@pytest.mark.slow
def test_layouts_that_repeat_a_plan_have_their_walls_moved_apart(tmp_path: Path) -> None:
    brief = tmp_path / "apartment-5.json"
    brief.write_text(Path("examples/apartment-5.json").read_text())
    # 20 s a layout, not the default 2 s: each ends at its first good layout, and the
    # seeds' plans (repeated as measured) come out the same on a busy machine.
    done = floorplan("batch", brief, "-n", "16", "-o", "out", "--processes", "2", "-q",
                     "--time-limit", "20", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    out = tmp_path / "out"
    summary = _summary(out)
    rows = summary["rows"]
    assert summary["valid"] == 16 and summary["spread"] == sum(r["spread"] for r in rows)
    assert not list(out.glob(".*.spread.*"))
    for row in rows:  # every file holds the layout its row describes, moved or not
        layout = json.loads((out / row["file"]).read_text())
        assert layout["report"]["valid"]
        assert layout["report"]["objective"] == pytest.approx(row["objective"], abs=1e-5)
    plain = floorplan("batch", brief, "-n", "16", "-o", "plain", "--processes", "2",
                      "--no-spread", "--no-distinct", "-q", "--time-limit", "20", cwd=tmp_path)
    assert plain.returncode == EXIT_OK, plain.stderr
    unspread = _summary(tmp_path / "plain")
    assert unspread["spread"] == 0
    # Seeds 0-15 repeat two plans of the 16 (measured: 14 distinct); moved apart,
    # every plan is new.
    assert summary["distinct_plans"] >= 15 and summary["spread"] >= 1


def test_invalid_brief_is_refused_before_anything_runs(tmp_path: Path) -> None:
    brief = write_problem(tmp_path, {**TINY, "rooms": []}, "bad.json")
    done = floorplan("batch", brief, "-n", "2", "-o", "out", cwd=tmp_path)
    assert done.returncode == 2
    assert "bad.json: invalid problem" in done.stderr
    assert not (tmp_path / "out").exists()


# -- the warm pool, with real processes ------------------------------------------------


def square(x: int) -> int:
    return x * x


def crash_on_three(x: int) -> int:
    if x == 3:
        os._exit(9)
    return x


def hang_on_two(x: int) -> int:
    if x == 2:
        time.sleep(60)
    return x


def pid(_: int) -> int:
    return os.getpid()


def _run(function, keys, limit=30.0):  # type: ignore[no-untyped-def]
    with WarmPool(2, warm_up=__name__) as pool:
        return {o.key: o for o in pool.results((k, function, k, limit) for k in keys)}


@pytest.mark.slow
def test_pool_runs_every_task_on_warm_workers() -> None:
    outcomes = _run(square, range(8))
    assert {k: o.result for k, o in outcomes.items()} == {k: k * k for k in range(8)}
    pids = {o.result for o in _run(pid, range(10)).values()}
    assert len(pids) <= 2  # the same two processes served every task


@pytest.mark.slow
def test_a_task_added_while_others_run_is_handed_out() -> None:
    # `floorplan batch --distinct` adds a task when an outcome asks for it; until then
    # its task list says "none yet" (None) rather than ending.
    asked: list[int] = []
    seen: list[int] = []

    def tasks():  # type: ignore[no-untyped-def]
        yield (1, square, 1, 30.0)
        while not seen:
            yield None
        yield (2, square, 2, 30.0)

    with WarmPool(2, warm_up=__name__) as pool:
        for outcome in pool.results(tasks()):
            asked.append(outcome.key)
            seen.append(outcome.result)
    assert asked == [1, 2] and seen == [1, 4]


@pytest.mark.slow
def test_a_crash_fails_one_task_not_the_pool() -> None:
    outcomes = _run(crash_on_three, range(6))
    assert outcomes[3].error is not None and "died" in outcomes[3].error
    assert {k: o.result for k, o in outcomes.items() if k != 3} == {0: 0, 1: 1, 2: 2, 4: 4,
                                                                    5: 5}


@pytest.mark.slow
def test_a_task_past_its_hard_limit_is_killed() -> None:
    # Killed, not waited for: the hanging task's error says so (its 60 s sleep would end
    # with a result and no error).
    outcomes = _run(hang_on_two, range(4), limit=1.0)
    assert outcomes[2].error is not None and "hard limit" in outcomes[2].error
    assert [outcomes[k].result for k in (0, 1, 3)] == [0, 1, 3]
