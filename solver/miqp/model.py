"""A level's SCIP model with its rectangle variables: what every constraint family and
objective term (`solver.miqp.formulation`, `solver.miqp.objective`) adds to."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pyscipopt import Model, Variable

from floorplan.solver.geometry import Box
from floorplan.solver.miqp.spec import LevelSpec

#: Every rectangle of a level by name, fixed ones included: what a start is made of.
Boxes = Mapping[str, Box]
#: How a variable's value follows from the rectangles (`LevelModel.derive`).
Valuation = Callable[[Boxes], float]


@dataclass
class RectVars:
    x: Variable
    y: Variable
    w: Variable
    d: Variable


@dataclass
class LevelModel:
    """A built, unsolved SCIP model and its named variables."""

    spec: LevelSpec
    model: Model
    rects: dict[str, RectVars]
    families: list[str] = field(default_factory=list)
    #: The slack variables of soft constraints, each priced in the objective.
    slacks: list[Variable] = field(default_factory=list)
    #: Binaries of rectangles enclosing a notch, with its area: the rectangle's area
    #: counts that much less as covered floor.
    enclosures: list[tuple[Variable, float]] = field(default_factory=list)
    #: Event callbacks of the current solve; SCIP takes each handler once per model, so
    #: the runner installs handlers once and swaps what they call.
    hooks: dict[str, Any] = field(default_factory=dict)
    #: SCIP's primal heuristics run aggressively: for a first layout that the default
    #: settings did not find (`solver.pipeline.first_layout`).
    aggressive: bool = False
    #: How every variable other than the rectangles' x, y, w, d follows from their
    #: boxes, registered where the variable is created: a start is then computed in
    #: closed form (`scip_run.start_values`), with no SCIP solve to complete it.
    derived: list[tuple[Variable, Valuation]] = field(default_factory=list)
    #: The relative gap at which SCIP may stop (None: `scip_run.GAP_LIMIT`): a model
    #: whose objective only leans the layout one way need not be solved closely.
    gap: float | None = None

    def derive(self, var: Variable, value: Valuation) -> Variable:
        """Record how `var`'s value follows from the rectangles' boxes; returns `var`.
        A binary's value must satisfy its big-M constraints whenever the boxes satisfy
        the family, and a slack's is the least that satisfies its constraints."""
        self.derived.append((var, value))
        return var

    @property
    def big_m_x(self) -> float:
        """The smallest valid M for x-disjunctions: the width spanned by the region and
        any fixed rectangle (which may lie outside it)."""
        fixed = [r.fixed for r in self.spec.rects if r.fixed is not None]
        r = self.spec.region
        return max([r.x1, *(b.x1 for b in fixed)]) - min([r.x0, *(b.x0 for b in fixed)])

    @property
    def big_m_y(self) -> float:
        """As `big_m_x`, for y."""
        fixed = [r.fixed for r in self.spec.rects if r.fixed is not None]
        r = self.spec.region
        return max([r.y1, *(b.y1 for b in fixed)]) - min([r.y0, *(b.y0 for b in fixed)])


def add_rect_vars(m: Model, spec: LevelSpec) -> dict[str, RectVars]:
    """Position and size variables, bounded only by the region's box."""
    rects = {}
    for r in spec.rects:
        b = r.fixed
        rects[r.name] = RectVars(
            x=m.addVar(f"x[{r.name}]", lb=b.x0 if b else spec.region.x0,
                       ub=b.x0 if b else spec.region.x1),
            y=m.addVar(f"y[{r.name}]", lb=b.y0 if b else spec.region.y0,
                       ub=b.y0 if b else spec.region.y1),
            w=m.addVar(f"w[{r.name}]", lb=b.width if b else 0,
                       ub=b.width if b else spec.region.width),
            d=m.addVar(f"d[{r.name}]", lb=b.depth if b else 0,
                       ub=b.depth if b else spec.region.depth),
        )
    return rects


def _slack(lm: LevelModel, name: str, value: Valuation) -> Variable:
    """A slack variable of a soft constraint (metres), priced in the objective; `value`
    is its least value that satisfies the constraint at given boxes."""
    slack = lm.derive(lm.model.addVar(f"slack[{name}]", lb=0.0, ub=None), value)
    lm.slacks.append(slack)
    return slack
