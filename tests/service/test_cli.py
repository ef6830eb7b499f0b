"""The `floorplan` command, run for real (``python -m floorplan.service``) in a subprocess."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import pytest

from floorplan.models import ConstraintCheck, Layout, Report
from floorplan.service.cli.exits import EXIT_INTERRUPTED, EXIT_INVALID, EXIT_NO_LAYOUT, EXIT_OK
from floorplan.service.cli.progress import ProgressPrinter, invalid_layout_warning
from floorplan.service.cli.progress import progress_line as format_progress
from floorplan.solver.events import Phase, SolveEvent
from tests.paths import ROOT
from tests.solver.pipeline.test_parallel import TWO_WINGS

# A 6 x 4 flat, two rooms side by side: solved in well under a second.
TINY: dict[str, Any] = {
    "name": "tiny",
    "boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
    "entrance": [1.0, 0.0],
    "rooms": [
        {"id": "living", "type": "living", "min_size": [2, 2], "target_size": [3.5, 4]},
        {"id": "kitchen", "type": "kitchen", "min_size": [1.5, 2], "target_size": [2.5, 4]},
    ],
    "adjacency": [{"a": "living", "b": "kitchen"}],
}
PROGRESS = re.compile(r"^\[\s*\d+\.\d\ds\] level \d+", re.MULTILINE)
FIRST_LAYOUT = re.compile(r"size bounds .*: (optimal|feasible)")
SUMMARY = re.compile(
    r"^(\d+) rooms  coverage [\d.]+%  levels \d+  termination (\w+)  valid (yes|no)  "
    r"solve time [\d.]+ s$", re.MULTILINE)


def floorplan(*args: str | Path, cwd: Path, **kw: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "floorplan.service", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=60, env=_env(), **kw)


def _env() -> dict[str, str]:
    # The tests may run from anywhere: make sure the child imports this checkout.
    return {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}


def write_problem(directory: Path, problem: dict[str, Any], name: str = "problem.json") -> Path:
    path = directory / name
    path.write_text(json.dumps(problem))
    return path


@pytest.mark.slow
def test_solve_writes_layout_svg_progress_and_summary(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TINY)
    (tmp_path / "out").mkdir()
    done = floorplan("solve", problem, "-o", "out/layout.json", "--svg", "out/plan.svg",
                     "--time-limit", "2", "--seed", "3", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    assert done.stdout == ""
    layout = Layout.model_validate_json((tmp_path / "out/layout.json").read_text())
    assert {r.id for r in layout.rooms} == {"living", "kitchen"}
    assert layout.report.valid
    svg = ET.parse(tmp_path / "out/plan.svg").getroot()
    assert svg.tag == "{http://www.w3.org/2000/svg}svg"
    assert PROGRESS.search(done.stderr), done.stderr
    summary = SUMMARY.search(done.stderr)
    assert summary is not None, done.stderr
    assert summary.group(1) == "2" and summary.group(3) == "yes"


@pytest.mark.slow
def test_layout_goes_to_stdout_without_output_file_and_quiet_is_quiet(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TINY)
    done = floorplan("solve", problem, "--time-limit", "1", "--quiet", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    assert Layout.model_validate_json(done.stdout).rooms
    assert done.stderr == ""


def test_invalid_problem_exits_2_naming_each_field(tmp_path: Path) -> None:
    bad = json.loads(json.dumps(TINY))
    bad["rooms"][1]["max_size"] = [1.0, 5.0]  # min width 1.5 > max width 1.0
    problem = write_problem(tmp_path, bad)
    done = floorplan("solve", problem, "-o", "layout.json", cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert "problem.json" in done.stderr
    assert re.search(r"^\s*rooms\.1\.min_size\.0: minimum width 1.5 exceeds maximum 1.0$",
                     done.stderr, re.MULTILINE), done.stderr
    assert not (tmp_path / "layout.json").exists()


def test_point_outside_the_outline_is_named_by_path(tmp_path: Path) -> None:
    bad = json.loads(json.dumps(TINY))
    bad["rooms"][0]["positions"] = [[9.0, 1.0]]
    done = floorplan("solve", write_problem(tmp_path, bad), cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert re.search(r"^\s*rooms\.0\.positions\.0: .*outside the boundary", done.stderr,
                     re.MULTILINE), done.stderr


def test_broken_json_exits_2_with_the_position(tmp_path: Path) -> None:
    path = tmp_path / "broken.json"
    path.write_text('{"boundary": [[0, 0], [6, 0]],\n "rooms": [\n')
    done = floorplan("solve", path, cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert "broken.json" in done.stderr
    assert re.search(r"line \d+, column \d+", done.stderr), done.stderr


def test_missing_file_and_bad_override_exit_2(tmp_path: Path) -> None:
    missing = floorplan("solve", "nowhere.json", cwd=tmp_path)
    assert missing.returncode == EXIT_INVALID
    assert "nowhere.json" in missing.stderr
    bad_limit = floorplan("solve", write_problem(tmp_path, TINY), "--time-limit", "-1",
                          cwd=tmp_path)
    assert bad_limit.returncode == EXIT_INVALID
    assert "options.time_limit" in bad_limit.stderr


@pytest.mark.slow
def test_processes_solve_the_sub_domains_in_a_pool(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TWO_WINGS)
    done = floorplan("solve", problem, "-o", "layout.json", "--processes", "2", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    assert Layout.model_validate_json((tmp_path / "layout.json").read_text()).report.valid
    solved = [line for line in done.stderr.splitlines()
              if re.search(r" sub \d+/\d+ .*rooms ", line)]
    # A sub-domain solved in the pool says how long it took there.
    assert solved and all(re.search(r" in [\d.]+ s$", line) for line in solved), done.stderr
    alone = floorplan("solve", problem, "-o", "alone.json", cwd=tmp_path)
    assert alone.returncode == EXIT_OK, alone.stderr
    assert not re.search(r" in [\d.]+ s$", alone.stderr, re.MULTILINE)
    for bad in ("0", "two"):
        refused = floorplan("solve", problem, "--processes", bad, cwd=tmp_path)
        assert refused.returncode == EXIT_INVALID and "--processes" in refused.stderr


def test_infeasible_problem_exits_3_and_the_json_says_why(tmp_path: Path) -> None:
    too_big = {
        "name": "too-big",
        "boundary": [[0, 0], [4, 0], [4, 4], [0, 4]],
        "rooms": [{"id": "a", "min_size": [3, 3]}, {"id": "b", "min_size": [3, 3]}],
    }
    done = floorplan("solve", write_problem(tmp_path, too_big), "-o", "layout.json",
                     "--time-limit", "1", cwd=tmp_path)
    assert done.returncode == EXIT_NO_LAYOUT
    layout = Layout.model_validate_json((tmp_path / "layout.json").read_text())
    assert layout.rooms == []
    assert layout.report.termination == "infeasible"
    assert layout.report.infeasibility is not None
    assert layout.report.infeasibility.reason in done.stderr
    assert any("18.00" in f for f in layout.report.infeasibility.findings)


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="POSIX signals")
@pytest.mark.parametrize("processes", ["1", "2"])  # a pool's start once unblocked SIGINT
def test_ctrl_c_stops_the_solve_and_writes_the_layout(tmp_path: Path, processes: str) -> None:
    problem = ROOT / "examples" / "apartment-15-obstacles.json"
    proc = subprocess.Popen(
        [sys.executable, "-m", "floorplan.service", "solve", str(problem), "-o", "layout.json",
         "--time-limit", "30", "--processes", processes],
        cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        env=_env(),
        # A shell may start background jobs with SIGINT ignored; give the child the default.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.stderr is not None
    # Wait for a first layout, for an incumbent of the MIQP improving it, and a moment
    # more: the signal then comes while SCIP works, when SCIP's own Ctrl-C handler
    # would take it and end that one MIQP only, and the solve would run on to its 30 s.
    seen: list[str] = []
    while not (FIRST_LAYOUT.search("".join(seen[:-1])) and "new incumbent" in seen[-1]):
        line = proc.stderr.readline()
        assert line, "the solve ended early:\n" + "".join(seen)
        assert PROGRESS.match(line), line
        seen.append(line)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    rest = proc.stderr.read()
    assert proc.wait(timeout=120) == EXIT_OK, rest
    # Interrupted: the signal stopped the whole solve, not one MIQP of it.
    layout = Layout.model_validate_json((tmp_path / "layout.json").read_text())
    assert layout.report.termination == "interrupted"
    assert layout.rooms
    assert "interrupted" in rest


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "pthread_sigmask"), reason="POSIX signals")
def test_ctrl_c_before_any_layout_exits_130(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "floorplan.service", "solve",
         str(ROOT / "examples" / "apartment-15-obstacles.json"),
         "-o", "layout.json", "--time-limit", "30"],
        cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        env=_env(), preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.stderr is not None
    # Level 1 starts; its first layout takes this problem some 0.7 s.
    first = proc.stderr.readline()
    assert PROGRESS.match(first), first
    proc.send_signal(signal.SIGINT)
    rest = proc.stderr.read()
    assert proc.wait(timeout=30) == EXIT_INTERRUPTED, rest
    layout = Layout.model_validate_json((tmp_path / "layout.json").read_text())
    assert layout.report.termination == "interrupted"
    assert layout.rooms == []


def test_progress_line_format() -> None:
    event = SolveEvent(Phase.SUBDOMAIN, level=2, elapsed=1.234, subdomain=1, subdomains=3,
                       objective=12.411, dual_bound=3.2, detail="rooms a, b: optimal")
    assert format_progress(event) == (
        "[  1.23s] level 2 sub 1/3  obj 12.41  bound 3.20  rooms a, b: optimal")
    assert format_progress(SolveEvent(Phase.INCUMBENT, level=1, elapsed=0.5, objective=-0.001,
                                      dual_bound=-1e20)) == (
        "[  0.50s] level 1  obj 0.00  bound -inf  new incumbent")


def test_incumbents_are_throttled_but_the_last_one_shows(tmp_path: Path) -> None:
    now = [0.0]
    out = tmp_path / "progress.txt"
    with out.open("w") as stream:
        printer = ProgressPrinter(stream, interval=0.25, clock=lambda: now[0])
        for k in range(10):  # ten incumbents within 0.09 s: one printed, the last held
            now[0] = k * 0.01
            printer(SolveEvent(Phase.INCUMBENT, level=1, elapsed=now[0], objective=10.0 - k))
        printer(SolveEvent(Phase.DONE, level=1, elapsed=0.1, detail="coverage 100.0%"))
    lines = out.read_text().splitlines()
    fields = [line.split("] ", 1)[1].split("  ")[1] for line in lines]
    assert fields == ["obj 10.00", "obj 1.00", "coverage 100.0%"]


def test_invalid_layout_warning_lists_the_failed_checks() -> None:
    report = Report(coverage=0.9, uncovered_area=1.0, valid=False, constraints=[
        ConstraintCheck(kind="size", rooms=["a"], satisfied=True),
        ConstraintCheck(kind="adjacency", rooms=["a", "b"], satisfied=False,
                        detail="contact 0.40 m < 0.90 m"),
    ])
    assert invalid_layout_warning(Layout(report=report)).splitlines() == [
        "floorplan: warning: the layout fails 1 check(s):",
        "  adjacency a, b: contact 0.40 m < 0.90 m",
    ]


# Templates (paper Sec. 5.4): a bare list of room types is a problem.

TEMPLATED: dict[str, Any] = {
    "name": "templated-flat",
    "boundary": [[0, 0], [9, 0], [9, 7], [0, 7]],
    "entrance": [4.5, 0],
    "template": "residential",
    "rooms": ["living", "kitchen", "bedroom", "bedroom", "bathroom"],
}


@pytest.mark.slow
def test_a_templated_problem_solves_from_the_command_line(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TEMPLATED)
    done = floorplan("solve", problem, "-o", "layout.json", "--time-limit", "2",
                     "--seed", "1", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    layout = Layout.model_validate_json((tmp_path / "layout.json").read_text())
    assert {r.id for r in layout.rooms} == {"living", "kitchen", "bedroom-1", "bedroom-2",
                                            "bathroom"}
    assert layout.report.valid


@pytest.mark.slow
def test_expand_writes_the_problem_as_it_would_be_solved_and_it_solves_as_is(
    tmp_path: Path,
) -> None:
    problem = write_problem(tmp_path, TEMPLATED)
    done = floorplan("solve", problem, "--expand", "--seed", "4", "-o", "expanded.json",
                     cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    text = (tmp_path / "expanded.json").read_text()
    assert '"boundary": [[0.0, 0.0], [9.0, 0.0], [9.0, 7.0], [0.0, 7.0]]' in text
    expanded = json.loads(text)
    assert "template" not in expanded and "openings" not in expanded  # defaults stay implicit
    assert expanded["options"] == {"seed": 4}
    assert all({"id", "min_size", "max_size", "target_size"} <= set(r) for r in expanded["rooms"])
    assert expanded["adjacency"]
    # The file is a plain problem: edit it (here: drop the adjacencies) and solve it.
    expanded["adjacency"] = []
    solved = floorplan("solve", write_problem(tmp_path, expanded, "edited.json"),
                       "--time-limit", "1", "-q", cwd=tmp_path)
    assert solved.returncode == EXIT_OK, solved.stderr
    assert not [c for c in Layout.model_validate_json(solved.stdout).report.constraints
                if c.kind == "adjacency"]


def test_expand_refuses_a_plan_format(tmp_path: Path) -> None:
    done = floorplan("solve", write_problem(tmp_path, TEMPLATED), "--expand", "--svg", "p.svg",
                     cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert "--expand" in done.stderr


def test_unknown_template_and_room_type_exit_2_naming_each_field(tmp_path: Path) -> None:
    bad = {**TEMPLATED, "template": "castle", "rooms": ["living", "ballroom"]}
    done = floorplan("solve", write_problem(tmp_path, bad), cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert re.search(r"^\s*rooms\.1: unknown room type 'ballroom'", done.stderr,
                     re.MULTILINE), done.stderr
    bad = {**TEMPLATED, "template": "castle"}
    done = floorplan("solve", write_problem(tmp_path, bad), cwd=tmp_path)
    assert re.search(r"^\s*template: .*'residential'", done.stderr, re.MULTILINE), done.stderr
