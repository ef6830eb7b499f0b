"""The layers of docs/architecture.md, as import-linter contracts (pyproject.toml): they
hold today, and each import cycle the code once had would break one of them again."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import grimp
import pytest
from importlinter.api import read_configuration
from importlinter.contracts.acyclic_siblings import AcyclicSiblingsContract
from importlinter.contracts.forbidden import ForbiddenContract
from importlinter.contracts.layers import LayersContract

from tests.paths import ROOT

CONTRACT_TYPES = {"layers": LayersContract, "forbidden": ForbiddenContract,
                  "acyclic_siblings": AcyclicSiblingsContract}
#: The cycles the code had before it was split into layers (docs/architecture.md, "The
#: layers"), each as the imports that would bring it back in today's module names.
OLD_CYCLES = {
    "solve <-> regions": [
        ("floorplan.solver.pipeline.regions.run", "floorplan.solver.pipeline.dispatch")],
    "solve <-> storeys": [
        ("floorplan.solver.pipeline.storeys", "floorplan.solver.pipeline.dispatch")],
    "the solve child <-> the Celery backend": [
        ("floorplan.service.jobs.child", "floorplan.service.jobs.celery.backend")],
    "problem <-> storeys": [("floorplan.models.storeys", "floorplan.models.problem")],
}


@pytest.fixture(scope="module")
def options() -> dict[str, Any]:
    return read_configuration(str(ROOT / "pyproject.toml"))


@pytest.fixture(scope="module")
def graph(options: dict[str, Any]) -> grimp.ImportGraph:
    """The project's import graph, built once for the module's tests."""
    return grimp.build_graph(*options["session_options"]["root_packages"],
                             exclude_type_checking_imports=True, cache_dir=None)


def _broken(options: dict[str, Any], graph: grimp.ImportGraph,
            extra: list[tuple[str, str]]) -> list[str]:
    """The names of the contracts broken once the imports `extra` are added (they are
    taken out again afterwards, so the graph serves the next test)."""
    session = options["session_options"]
    for importer, imported in extra:
        graph.add_import(importer=importer, imported=imported)
    try:
        broken = []
        for contract_options in options["contracts_options"]:
            kind = CONTRACT_TYPES[contract_options["type"]]
            contract = kind(name=contract_options["name"], session_options=session,
                            contract_options=contract_options)
            if not contract.check(graph, verbose=False).kept:
                broken.append(contract_options["name"])
        return broken
    finally:
        for importer, imported in extra:
            graph.remove_import(importer=importer, imported=imported)


def test_every_layer_contract_holds(options: dict[str, Any], graph: grimp.ImportGraph) -> None:
    assert _broken(options, graph, []) == []


def test_the_command_line_linter_agrees() -> None:
    # The venv's own script when its bin folder is not on PATH (a venv used unactivated).
    beside = Path(sys.executable).parent / "lint-imports"
    lint = shutil.which("lint-imports") or (str(beside) if beside.exists() else None)
    assert lint is not None
    done = subprocess.run([lint], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.mark.parametrize("cycle", sorted(OLD_CYCLES))
def test_each_old_import_cycle_would_break_a_contract(
        cycle: str, options: dict[str, Any], graph: grimp.ImportGraph) -> None:
    assert _broken(options, graph, OLD_CYCLES[cycle])
