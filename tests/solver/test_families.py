"""The one list of constraint families (solver/families.py) and the three places that
must follow it: the MIQP's builders, the independent checker, and the docs' table."""

from __future__ import annotations

import re

from floorplan.solver.families import FAMILIES, family, markdown_table
from floorplan.solver.miqp import formulation
from floorplan.solver.verify.checker import FAMILY_CHECKS
from tests.paths import ROOT


def test_every_family_has_its_builder_citing_its_equation() -> None:
    assert list(formulation.BUILDERS) == [f.symbol for f in FAMILIES]
    assert tuple(formulation.BUILDERS.values()) == formulation.FAMILIES
    for f in FAMILIES:
        builder = formulation.BUILDERS[f.symbol]
        assert builder.__name__ == f.builder
        for number in re.findall(r"\d+", f.equation):
            assert f"Eq. {number}" in (builder.__doc__ or ""), (f.symbol, number)


def test_every_checked_family_has_its_check_and_no_check_is_orphaned() -> None:
    checked = {f.check for f in FAMILIES if f.check is not None}
    assert checked == {"inside", *FAMILY_CHECKS}


def test_active_families_name_registered_families_only() -> None:
    from floorplan.solver.geometry import Box
    from floorplan.solver.miqp.spec import LevelSpec

    spec = LevelSpec(name="t", region=Box(0, 0, 4, 4), blocked=(), free_area=16.0, rects=())
    names = formulation.active_families(spec)
    assert names == ["C_inside", "C_overlap", "C_size"]
    assert all(family(n) for n in names)


def test_the_docs_table_is_the_registry() -> None:
    assert markdown_table() in (ROOT / "docs" / "method.md").read_text()
