"""What `floorplan` writes where, run for real in a subprocess: never clobbering a
device, an extension no format has refused before solving, `--version`, help on a
bare `floorplan`; and docs/cli.md's exit codes and format lists against the code."""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path

from floorplan.models.formats import FORMAT_NAMES
from floorplan.service.cli import exits
from floorplan.service.cli.exits import EXIT_INVALID, EXIT_OK
from tests.paths import ROOT
from tests.service.test_cli import TINY, floorplan, write_problem

CLI_DOC = ROOT / "docs" / "cli.md"


def test_solve_to_dev_null_leaves_it_a_device(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TINY)
    done = floorplan("solve", problem, "-o", "/dev/null", "-q", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_an_extension_no_format_has_is_refused_before_solving(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TINY)
    done = floorplan("solve", problem, "-o", "plan.pdf", cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert "no format has the extension .pdf" in done.stderr and "--format" in done.stderr
    assert "rooms" not in done.stderr  # nothing was solved: no summary
    assert not (tmp_path / "plan.pdf").exists()
    # Said in so many words, the name may be anything.
    done = floorplan("solve", problem, "-o", "plan.pdf", "--format", "svg", "-q", cwd=tmp_path)
    assert done.returncode == EXIT_OK, done.stderr
    assert "<svg" in (tmp_path / "plan.pdf").read_text()


def test_submit_refuses_an_unknown_extension_before_sending_anything(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TINY)
    # Nothing listens there: the refusal must come first.
    done = floorplan("submit", problem, "-o", "plan.pdf", "--server", "http://127.0.0.1:9",
                     cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert "no format has the extension .pdf" in done.stderr


def test_an_output_folder_that_does_not_exist_is_invalid_input(tmp_path: Path) -> None:
    problem = write_problem(tmp_path, TINY)
    done = floorplan("solve", problem, "-o", "missing/layout.json", cwd=tmp_path)
    assert done.returncode == EXIT_INVALID
    assert "does not exist" in done.stderr


def test_version_and_help_on_a_bare_floorplan(tmp_path: Path) -> None:
    version = floorplan("--version", cwd=tmp_path)
    assert version.returncode == 0
    assert re.fullmatch(r"floorplan \d+\.\d+\.\d+\S*\n", version.stdout)
    bare = floorplan(cwd=tmp_path)
    assert bare.returncode == EXIT_INVALID
    for command in ("solve", "batch", "serve", "worker"):
        assert re.search(rf"^\s+{command}\s+\S", bare.stderr, re.MULTILINE), bare.stderr


def _section(name: str) -> str:
    text = CLI_DOC.read_text(encoding="utf-8")
    start = text.index(f"## {name}\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end > 0 else None]


def _exit_codes(section: str) -> set[int]:
    return {int(code) for code in re.findall(r"^\| (\d+) \|", section, re.MULTILINE)}


def test_the_documented_exit_codes_are_the_codes() -> None:
    solve = {getattr(exits, name) for name in dir(exits) if name.startswith("EXIT_")}
    assert _exit_codes(_section("floorplan solve")) == solve
    # batch: no layout written to a file of its own, so no EXIT_FAILURE.
    assert _exit_codes(_section("floorplan batch")) == solve - {exits.EXIT_FAILURE}


def test_the_documented_format_lists_are_the_formats() -> None:
    for name in ("floorplan solve", "floorplan batch"):
        lists = re.findall(r"--format `?([a-z|]+)", _section(name))
        assert lists, name
        for listed in lists:
            assert tuple(listed.split("|")) == FORMAT_NAMES, (name, listed)
