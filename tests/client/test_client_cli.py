"""`floorplan submit`, run for real (``python -m floorplan.service submit``) against a real
`floorplan serve` process."""

from __future__ import annotations

import io
import json
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from floorplan_client import (
    Client,
    Event,
    JobStatus,
    NoResultYet,
    ProgressEvent,
    StatusEvent,
)
from floorplan_client.cli import (
    EXIT_FAILURE,
    EXIT_INVALID,
    EXIT_NO_LAYOUT,
    EXIT_OK,
)
from floorplan_client.cli.display import PlainDisplay, RichDisplay
from floorplan_client.models import Layout, Termination
from floorplan_client.types import Progress
from tests.client.test_client import CROWDED
from tests.servers import Server
from tests.service.test_service import LONG, SMALL


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("data")).start()
    yield s
    s.stop()


def problem_file(tmp_path: Path, problem: dict[str, Any], name: str = "problem.json") -> Path:
    path = tmp_path / name
    path.write_text(json.dumps(problem))
    return path


def submit(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "floorplan.service", "submit", *map(str, args)],
                          capture_output=True, text=True, timeout=120, cwd=cwd)


@pytest.mark.slow
def test_submit_without_wait_prints_the_job_id(server: Server, tmp_path: Path) -> None:
    done = submit(problem_file(tmp_path, SMALL), "--server", server.url, cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    job_id = done.stdout.strip()
    with Client(server.url, api_key=None) as fp:
        assert fp.get(job_id).wait(timeout=60).report.valid


@pytest.mark.slow
def test_submit_wait_writes_the_layout_and_the_plan(server: Server, tmp_path: Path) -> None:
    done = submit(problem_file(tmp_path, SMALL), "--server", server.url, "--wait",
                  "-o", "layout.json", "--svg", "plan.svg", "--time-limit", "1", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    layout = Layout.model_validate_json((tmp_path / "layout.json").read_text())
    assert layout.report.valid and {r.id for r in layout.rooms} == {"living", "bed"}
    assert "<svg" in (tmp_path / "plan.svg").read_text()
    assert "queued on" in done.stderr and "running" in done.stderr
    assert "2 rooms  coverage" in done.stderr and done.stdout == ""
    # Without -o, the layout goes to stdout, here as the service's GeoJSON.
    quiet = submit(problem_file(tmp_path, SMALL), "--server", server.url, "--wait", "-q",
                   "--format", "geojson", cwd=tmp_path)
    assert quiet.returncode == EXIT_OK and quiet.stderr == ""
    assert json.loads(quiet.stdout)["type"] == "FeatureCollection"


@pytest.mark.slow
def test_refused_and_infeasible_problems(server: Server, tmp_path: Path) -> None:
    ghost = {**SMALL, "adjacency": [{"a": "living", "b": "ghost"}]}
    refused = submit(problem_file(tmp_path, ghost), "--server", server.url, cwd=tmp_path)
    assert refused.returncode == EXIT_INVALID
    assert "adjacency.0.b: unknown room id 'ghost'" in refused.stderr
    missing = submit(tmp_path / "missing.json", "--server", server.url, cwd=tmp_path)
    assert missing.returncode == EXIT_INVALID and "no such file" in missing.stderr

    infeasible = submit(problem_file(tmp_path, CROWDED), "--server", server.url, "--wait",
                        "-o", "report.json", cwd=tmp_path)
    assert infeasible.returncode == EXIT_NO_LAYOUT
    assert "no layout (infeasible)" in infeasible.stderr and "minimum sizes need" \
        in infeasible.stderr
    assert "constraints in conflict:\n    - rooms.0.min_size: " in infeasible.stderr
    report = Layout.model_validate_json((tmp_path / "report.json").read_text())
    assert report.rooms == [] and report.report.termination is Termination.INFEASIBLE


def test_no_service_is_a_failure(tmp_path: Path) -> None:
    done = submit(problem_file(tmp_path, SMALL), "--server", "http://127.0.0.1:9",
                  cwd=tmp_path)
    assert done.returncode == EXIT_FAILURE and "ConnectError" in done.stderr


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.slow
def test_ctrl_c_cancels_the_job_and_writes_the_best_layout(server: Server,
                                                           tmp_path: Path) -> None:
    with Client(server.url, api_key=None) as fp:
        before = {job.id for job in fp.list()}
        # SIGINT at its default in the child, whatever this process inherited: a shell
        # without job control starts background jobs (a CI runner's, say) with SIGINT
        # ignored, and Python then installs no KeyboardInterrupt handler at all.
        process = subprocess.Popen(
            [sys.executable, "-m", "floorplan.service", "submit", str(problem_file(tmp_path, LONG)),
             "--server", server.url, "-o", "layout.json"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
            preexec_fn=_default_sigint,
        )
        try:
            deadline = time.monotonic() + 30
            while not (new := [j for j in fp.list() if j.id not in before]):
                assert time.monotonic() < deadline, "the job did not arrive"
                time.sleep(0.1)
            job = new[0]
            while True:  # until the job has a layout to keep
                try:
                    job.result()
                    break
                except NoResultYet:
                    assert time.monotonic() < deadline, "no incumbent in time"
                    time.sleep(0.1)
            process.send_signal(signal.SIGINT)
            _, stderr = process.communicate(timeout=30)
        finally:
            if process.poll() is None:
                process.kill()
        assert process.returncode == EXIT_OK, stderr
        assert f"canceling job {job.id}" in stderr
        assert job.refresh().status is JobStatus.CANCELED
    layout = Layout.model_validate_json((tmp_path / "layout.json").read_text())
    assert layout.report.termination is Termination.INTERRUPTED and len(layout.rooms) == 12


def test_the_displays_show_status_level_objective_and_time() -> None:
    events: list[Event] = [StatusEvent(status=JobStatus.RUNNING),
              ProgressEvent(progress=Progress(level=2, subdomain=1, subdomains=3,
                                              objective=12.414)),
              StatusEvent(status=JobStatus.SUCCEEDED)]
    plain = io.StringIO()
    clock = iter([0.0, 0.1, 0.2, 0.3])
    display = PlainDisplay(plain, interval=0.0, clock=lambda: next(clock))
    for event in events:
        display.update(event)
    display.close()
    assert plain.getvalue().splitlines()[1] == \
        "[   0.2s] running  level 2 sub 1/3  objective 12.41"

    from rich.console import Console

    screen = io.StringIO()
    live = RichDisplay(Console(file=screen, force_terminal=True, width=100))
    for event in events:
        live.update(event)
    live.close()
    assert "succeeded  level 2 sub 1/3" in screen.getvalue()
    assert "objective 12.41" in screen.getvalue() and "0:00:0" in screen.getvalue()


def test_the_floorplan_command_loads_no_client_until_submit_runs() -> None:
    """`floorplan solve` builds the same parser and must import numpy only later. Of
    `models`, only `models.formats` (standard library only) may load: submit's --format
    choices come from it."""
    code = ("import sys; from floorplan.service.cli import add_serve; "
            "from floorplan.service.cli.solve import build_parser; "
            "from floorplan_client.cli import add_submit; "
            "build_parser((add_serve, add_submit)).parse_args(['submit', 'p.json']); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & "
            "{'numpy', 'httpx2', 'pydantic', 'rich'}) + sorted("
            "m for m in sys.modules if m.rsplit('.', 1)[0].endswith('models') "
            "and not m.endswith('.formats')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]"
