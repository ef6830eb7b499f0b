"""Tiny levels for the formulation's tests: a level of a few rectangles in a 6 x 4 region,
one constraint family at a time (with a control case), solved on SCIP."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from pyscipopt import Expr

from floorplan.solver.geometry import Box, boundary_edges
from floorplan.solver.miqp.formulation import (
    Family,
    build_level,
)
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import LevelResult, LevelStatus, run_level
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec

#: Every solve here is tiny; a generous cap that none should come near.
TIME_LIMIT = 5.0

#: Geometry read back from SCIP is exact to its feasibility tolerance (1e-6).
TOL = 1e-5

#: The objective's minimiser is compared to the analytic one at this tolerance.
ARGMIN_TOL = 1e-3

REGION = Box(0, 0, 6, 4)

SOLVED = (LevelStatus.OPTIMAL, LevelStatus.FEASIBLE)


def level(
    *rects: RectSpec,
    region: Box = REGION,
    blocked: Sequence[Box] = (),
    contacts: Sequence[ContactSpec] = (),
    envelopes: Sequence[EnvelopeSpec] = (),
    cover_weight: float = 1.0,
    size_weight: float = 1.0,
) -> LevelSpec:
    """A level over `region` (free area: the region minus `blocked`)."""
    return LevelSpec(
        name="test",
        region=region,
        blocked=tuple(blocked),
        free_area=region.area - sum(b.area for b in blocked),
        rects=rects,
        contacts=tuple(contacts),
        envelopes=tuple(envelopes),
        cover_weight=cover_weight,
        size_weight=size_weight,
    )


def rect(name: str, room: str | None = None, **fields: Any) -> RectSpec:
    """A rectangle, by default its own room."""
    return RectSpec(name=name, room=room or name, **fields)


def build(spec: LevelSpec, *families: Family) -> LevelModel:
    """The model with only `families` and no objective (tests set their own)."""
    return build_level(spec, families=families, feasibility=True)


def fix(
    lm: LevelModel,
    name: str,
    *,
    x: float | None = None,
    y: float | None = None,
    w: float | None = None,
    d: float | None = None,
) -> None:
    """Pin some of a rectangle's variables by collapsing their bounds."""
    v = lm.rects[name]
    for var, value in ((v.x, x), (v.y, y), (v.w, w), (v.d, d)):
        if value is not None:
            lm.model.chgVarLb(var, value)
            lm.model.chgVarUb(var, value)


def fix_box(lm: LevelModel, name: str, b: Box) -> None:
    fix(lm, name, x=b.x0, y=b.y0, w=b.width, d=b.depth)


def minimize(lm: LevelModel, expr: Expr) -> None:
    """A linear objective that pushes the rectangles where the test wants them."""
    lm.model.setObjective(expr, "minimize")


def solve(lm: LevelModel) -> LevelResult:
    result = run_level(lm, time_limit=TIME_LIMIT)
    assert result.status is not LevelStatus.NO_SOLUTION, "a tiny model hit the time limit"
    return result


def solved_rects(lm: LevelModel) -> dict[str, Box]:
    result = solve(lm)
    assert result.status in SOLVED
    assert result.rects is not None
    return result.rects


def shared(a: Box, b: Box) -> float:
    """Length of wall two rectangles share; sides within TOL count as one line (solved
    coordinates are off by rounding, which an exact polygon intersection would miss)."""
    x_run = max(0.0, min(a.x1, b.x1) - max(a.x0, b.x0))
    y_run = max(0.0, min(a.y1, b.y1) - max(a.y0, b.y0))
    side_by_side = abs(a.x1 - b.x0) <= TOL or abs(b.x1 - a.x0) <= TOL
    stacked = abs(a.y1 - b.y0) <= TOL or abs(b.y1 - a.y0) <= TOL
    return max(y_run if side_by_side else 0.0, x_run if stacked else 0.0)


def overlap_area(a: Box, b: Box) -> float:
    return float(a.to_polygon().intersection(b.to_polygon()).area)

# An L: the 6 x 4 box without its north-east 2 x 2 corner.
L_RING = [(0, 0), (6, 0), (6, 2), (4, 2), (4, 4), (0, 4)]
L_EDGES = boundary_edges(L_RING)
L_BLOCKED = (Box(4, 2, 6, 4),)
