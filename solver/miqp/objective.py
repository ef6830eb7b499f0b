"""The objective terms of a level (paper Eq. 12, with Eq. 3 and 6), the first layout's
band shortfall, and the price of soft constraints' slacks."""

from __future__ import annotations

from collections.abc import Mapping
from functools import partial
from typing import Any

from pyscipopt import quicksum

from floorplan.solver.miqp.model import Boxes, LevelModel
from floorplan.solver.miqp.spec import LevelSpec, RectSpec, aim, free_rects


def e_objective(lm: LevelModel) -> None:
    """Eq. 12: lambda_cover * E_cover (Eq. 3) + lambda_size * E_size (Eq. 6).

    SCIP takes no quadratic objective, so each rectangle's term
    lambda_s * ((w - w*)^2 + (d - d*)^2) - lambda_c * w * d is bounded by its own epigraph
    variable. With lambda_s >= lambda_c / 2 each term is convex (Hessian
    [[2 ls, -lc], [-lc, 2 ls]]), which SCIP detects. The constant Area(D) of E_cover is
    the objective offset. At given boxes each epigraph variable is its term's value."""
    m, spec = lm.model, lm.spec
    ls, lc = spec.size_weight, spec.cover_weight
    terms = []
    for r in free_rects(spec):
        v = lm.rects[r.name]
        # The variables' own upper bounds: a soft maximum leaves them the region's.
        w_hi, d_hi = v.w.getUbOriginal(), v.d.getUbOriginal()
        tw, td = aim(spec, r)
        bonus = spec.growth_weight * (td * w_hi + tw * d_hi)
        z = lm.derive(m.addVar(f"energy[{r.name}]", lb=-lc * w_hi * d_hi - bonus),
                      partial(_energy, spec, r))
        growth = spec.growth_weight * (td * v.w + tw * v.d)
        m.addCons(
            ls * ((v.w - tw) * (v.w - tw) + (v.d - td) * (v.d - td)) - lc * v.w * v.d - growth
            <= z,
            name=f"energy_epigraph[{r.name}]",
        )
        terms.append(z)
    # A wrapped obstacle is inside the rectangle but no floor of the room's.
    wrapped = quicksum(lc * area * wrap for wrap, area in lm.enclosures)
    m.setObjective(quicksum(terms) + wrapped + e_violation(lm) + lc * spec.free_area,
                   "minimize")


def _energy(spec: LevelSpec, r: RectSpec, boxes: Boxes) -> float:
    """A rectangle's term of Eq. 12 (its epigraph's left side) at given boxes."""
    b, (tw, td) = boxes[r.name], aim(spec, r)
    w, d = b.width, b.depth
    return (spec.size_weight * ((w - tw) ** 2 + (d - td) ** 2) - spec.cover_weight * w * d
            - spec.growth_weight * (td * w + tw * d))


def e_band_shortfall(
    lm: LevelModel, bands: Mapping[str, tuple[tuple[float, float], tuple[float, float]]]
) -> None:
    """The objective of a first layout under the user's own bounds, when the schedule of
    size windows around the targets (Sec. 5.4) found none: the metres by which the named
    rectangles' widths and depths fall outside their (min, max) `bands`, summed, plus
    the soft constraints' price. A linear stand-in for E_size (Eq. 6) that SCIP's MILP
    heuristics handle as fast as a bare feasibility model. One room that no window can
    hold (a hall that must reach both side walls) makes every window infeasible; without
    this, every other room would then start anywhere within its bounds. At given boxes
    each shortfall variable is the shortfall itself."""
    m = lm.model
    shortfalls = []
    for r in free_rects(lm.spec):
        if r.name not in bands:
            continue
        v, (lo, hi) = lm.rects[r.name], bands[r.name]
        for axis, var, side in ((0, v.w, "w"), (1, v.d, "d")):
            below = lm.derive(m.addVar(f"band_below[{r.name},{side}]", lb=0.0),
                              partial(_band_miss, r.name, axis, lo[axis], -1))
            above = lm.derive(m.addVar(f"band_above[{r.name},{side}]", lb=0.0),
                              partial(_band_miss, r.name, axis, hi[axis], 1))
            m.addCons(var + below >= lo[axis], name=f"band_min[{r.name},{side}]")
            m.addCons(var - above <= hi[axis], name=f"band_max[{r.name},{side}]")
            shortfalls += [below, above]
    m.setObjective(quicksum(shortfalls) + e_violation(lm), "minimize")


def _band_miss(name: str, axis: int, bound: float, sense: int, boxes: Boxes) -> float:
    """How far the width (axis 0) or depth is below a band's minimum (`sense` -1) or
    above its maximum (+1)."""
    b = boxes[name]
    return max(0.0, sense * ((b.width if axis == 0 else b.depth) - bound))


def e_violation(lm: LevelModel) -> Any:
    """The price of the soft constraints' slacks: `violation_weight` per metre. Linear,
    so Eq. 12 stays convex; the exact-penalty form makes every slack zero whenever the
    rest of the objective gains less than the weight per metre of violation."""
    return lm.spec.violation_weight * quicksum(lm.slacks)
