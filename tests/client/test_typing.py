"""The SDK as its users' type checker sees it: both distributions installed as a user
installs them (built, not editable, so that only what they ship counts), then `mypy
--strict` on a small program that uses them alone. Every call reveals its real type,
not Any: an assignment of the wrong type is an error, which it could not be if the
types were Any; and every shipped package carries its `py.typed` marker (PEP 561)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.paths import ROOT

#: Builds two distributions and runs mypy: tens of seconds.
pytestmark = pytest.mark.slow

PROGRAM = textwrap.dedent('''
    from floorplan.models import Problem
    from floorplan_client import Client, NotFound

    with Client("http://127.0.0.1:8000") as fp:
        job = fp.submit({"name": "x"})
        layout = job.wait(timeout=10)
        reveal_type(layout)
        reveal_type(job.result())
        reveal_type(job.result("svg"))
        reveal_type(fp.validate({}))
        batch = fp.submit_batch({}, 3)
        reveal_type(batch)
        for line in fp.batch_results(batch.id):
            reveal_type(line)
        try:
            fp.get("nope")
        except NotFound as err:
            reveal_type(err)
        area: float = layout.rooms[0].area
        wrong: int = layout.name
        reveal_type(Problem.model_validate({}).rooms)
''')
#: What mypy reveals, line by line of PROGRAM's reveal_type calls.
REVEALED = [
    "floorplan_client.models.layout.Layout",
    "floorplan_client.models.layout.Layout",
    "str",
    "floorplan_client.models.jobs.Validation",
    "floorplan_client.models.jobs.BatchPublic",
    "floorplan_client.models.jobs.BatchLayoutLine",
    "floorplan_client._exceptions.NotFound",
    "list[floorplan.models.parts.Room]",
]
#: The packages each distribution ships, all typed.
SHIPPED = ["floorplan/models", "floorplan/solver", "floorplan/service", "floorplan_client",
           "floorplan_client/models"]


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Both distributions built and installed into a folder of their own (no
    dependencies: those are the test's environment's), from a copy of the sources
    so that the build leaves nothing in the repository."""
    where = tmp_path_factory.mktemp("typed")
    source = where / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "build", "data")
    for part in ("models", "solver", "service", "clients/python"):
        shutil.copytree(ROOT / part, source / part, ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    target = where / "site"
    run = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target",
         str(target), str(source), str(source / "clients" / "python")],
        capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    return target


def test_every_shipped_package_is_marked_typed(installed: Path) -> None:
    for package in SHIPPED:
        assert (installed / package / "py.typed").is_file(), package


def test_mypy_strict_sees_the_sdks_real_types(installed: Path, tmp_path: Path) -> None:
    program = tmp_path / "use_sdk.py"
    program.write_text(PROGRAM, encoding="utf-8")
    # The installed folder on the path is where mypy looks for installed packages
    # (PEP 561): there, only a package with py.typed has its annotations read.
    run = subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", "--cache-dir",
         os.devnull, program.name], cwd=tmp_path, capture_output=True, text=True,
        timeout=600, env={**os.environ, "PYTHONPATH": str(installed)})
    out = run.stdout
    assert re.findall(r'Revealed type is "([^"]+)"', out) == REVEALED, out
    errors = [line for line in out.splitlines() if ": error:" in line]
    # The one error is the wrong assignment: the name is a str, known as such.
    assert len(errors) == 1, out
    assert 'expression has type "str", variable has type "int"' in errors[0], out
