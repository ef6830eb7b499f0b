"""The installed import names are this project's own: `floorplan.models`,
`floorplan.solver`, `floorplan.service` (and the client's `floorplan_client`), never the
bare folder names another package may own."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tests.paths import ROOT

TOP_LEVEL = ("models", "solver", "service")


def test_every_package_folder_is_installed_under_the_floorplan_name() -> None:
    settings = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    folders = {".".join(init.parent.relative_to(ROOT).parts)
               for top in TOP_LEVEL for init in (ROOT / top).rglob("__init__.py")}
    assert set(settings["packages"]) == {f"floorplan.{name}" for name in folders}
    assert settings["package-dir"] == {f"floorplan.{top}": top for top in TOP_LEVEL}


@pytest.mark.parametrize("name", [*TOP_LEVEL, "floorplan_client.models.problem"])
def test_outside_the_repository_the_bare_names_are_not_ours(name: str, tmp_path: Path) -> None:
    """Run from an empty folder, so the repository is not on the path: `import models`
    finds nothing of ours, while the namespaced names import."""
    done = subprocess.run(
        [sys.executable, "-c", f"import importlib.util as u; print(u.find_spec({name!r}) "
         "is not None, u.find_spec('floorplan.models') is not None)"],
        cwd=tmp_path, capture_output=True, text=True, check=True)
    expected = "True True" if name.startswith("floorplan_client") else "False True"
    assert done.stdout.strip() == expected
