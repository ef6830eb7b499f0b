"""The MIQP of one level (paper Sec. 5.1-5.3), built on SCIP through pyscipopt.

A `LevelSpec` describes what to place: variable rectangles (`RectSpec`) inside a
region given as a bounding box minus constant `blocked` boxes. Level 1 has one
rectangle per room; a refinement level has the two halves of each split room plus
C_refine. Every constraint family is one function, named after the paper's symbol
and citing its equation (below; C_envelope in `envelope`); `solver.families` lists
them once.

Big-M values are per axis (the region's width for x-disjunctions, its depth for y),
the smallest that are valid, and the objective is minimised through one convex
epigraph per rectangle so SCIP can separate gradient cuts term by term.

Every variable other than the rectangles' x, y, w, d is registered, where it is
created, with how its value follows from the rectangles' boxes (`LevelModel.derive`):
a binary takes a value that satisfies its big-M constraints whenever the boxes satisfy
the family, a slack the least value its constraints allow (`valuation`). A start is
then a full solution computed in closed form (`scip_run.add_start`), not a SCIP solve.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

from pyscipopt import Model, Variable, quicksum

from floorplan.solver.families import FAMILIES as REGISTERED
from floorplan.solver.geometry import EPS, Box, Edge, Notch
from floorplan.solver.miqp.envelope import _either_orientation, c_envelope
from floorplan.solver.miqp.model import LevelModel, RectVars, _slack, add_rect_vars
from floorplan.solver.miqp.objective import e_objective, e_violation
from floorplan.solver.miqp.spec import LevelSpec, RectSpec, free_rects
from floorplan.solver.miqp.valuation import (
    _above,
    _apart,
    _below,
    _best_contact,
    _clear_side,
    _edge_picked,
    _nearest_edge,
    _point_miss,
    _ratio_miss,
    _side_apart,
    _size,
    _theta,
)
from floorplan.solver.soft import (
    SOFT_EDGE_CONTACT,
)


def c_size(lm: LevelModel) -> None:
    """C_size (Eq. 5): min <= w <= max and min <= d <= max, as variable bounds; a soft
    bound is a constraint with a slack instead (w + s >= min, w - s <= max)."""
    m = lm.model
    for r in free_rects(lm.spec):
        v = lm.rects[r.name]
        extents = (lm.spec.region.width, lm.spec.region.depth)
        for axis, var, name in ((0, v.w, "w"), (1, v.d, "d")):
            lo, hi = r.min_size[axis], r.max_size[axis]
            if "min_size" in r.soft and lo > r.floor[axis]:
                slack = _slack(lm, f"min_{name}[{r.name}]",
                               partial(_below, r.name, axis, lo))
                m.addCons(var + slack >= lo, name=f"size_min_{name}[{r.name}]")
                m.chgVarLb(var, r.floor[axis])
            else:
                m.chgVarLb(var, max(lo, r.floor[axis]))
            if "max_size" in r.soft and hi < extents[axis]:
                slack = _slack(lm, f"max_{name}[{r.name}]",
                               partial(_above, r.name, axis, hi))
                m.addCons(var - slack <= hi, name=f"size_max_{name}[{r.name}]")
                m.chgVarUb(var, extents[axis])
            else:
                m.chgVarUb(var, min(hi, extents[axis]))


def c_inside(lm: LevelModel) -> None:
    """C_inside (Eq. 1) for the region's bounding box, plus no overlap with any blocked
    box (obstacles, the box outside the outline, fixed rooms): Eq. 2 against constants;
    a notch may instead be enclosed (`_clear_or_wrap`)."""
    m, spec = lm.model, lm.spec
    for r in free_rects(spec):
        v = lm.rects[r.name]
        m.addCons(v.x + v.w <= spec.region.x1, name=f"inside_x[{r.name}]")
        m.addCons(v.y + v.d <= spec.region.y1, name=f"inside_y[{r.name}]")
        for k, b in enumerate(spec.blocked):
            if _may_intersect(r, spec.region, b):
                sides = _clear_sides(lm, r.name, v, b, tag=f"{k}", wraps=False)
                m.addCons(quicksum(sides) >= 1, name=f"clear[{r.name},{k}]")
        for k, n in enumerate(spec.notches):
            _clear_or_wrap(lm, r, v, k, n)


def _clear_sides(lm: LevelModel, name: str, v: RectVars, b: Box, tag: str,
                 *, wraps: bool) -> list[Variable]:
    """Eq. 2 against the constant box `b`: four binaries, each, when set, keeping the
    rectangle west, east, south or north of it. The caller demands one of them (or,
    when it `wraps`, the enclosure: then none is set unless a side is clear)."""
    m, mx, my = lm.model, lm.big_m_x, lm.big_m_y
    sides = [lm.derive(m.addVar(f"clear[{name},{tag},{s}]", vtype="B"),
                       partial(_clear_side, name, b, s, wraps)) for s in range(4)]
    m.addCons(v.x + v.w <= b.x0 + mx * (1 - sides[0]), name=f"clear_w[{name},{tag}]")
    m.addCons(v.x >= b.x1 - mx * (1 - sides[1]), name=f"clear_e[{name},{tag}]")
    m.addCons(v.y + v.d <= b.y0 + my * (1 - sides[2]), name=f"clear_s[{name},{tag}]")
    m.addCons(v.y >= b.y1 - my * (1 - sides[3]), name=f"clear_n[{name},{tag}]")
    return sides


def _clear_or_wrap(lm: LevelModel, r: RectSpec, v: RectVars, k: int, n: Notch) -> None:
    """Eq. 2 against a notch, with a fifth way out: the rectangle encloses its hull,
    and the room wraps around the obstacle (`Notch`)."""
    m, b, h = lm.model, n.obstacle, n.hull
    if not _may_intersect(r, lm.spec.region, b):
        return
    sides = _clear_sides(lm, r.name, v, b, tag=f"n{k}", wraps=r.may_wrap)
    if not r.may_wrap:
        m.addCons(quicksum(sides) >= 1, name=f"clear[{r.name},n{k}]")
        return
    mx, my = lm.big_m_x, lm.big_m_y
    # Wrapped exactly when no side is clear (C_inside then needs the hull enclosed).
    wrap = lm.derive(m.addVar(f"wrap[{r.name},n{k}]", vtype="B"),
                     lambda boxes: float(not _apart(boxes[r.name], b).clear))
    m.addCons(v.x <= h.x0 + mx * (1 - wrap), name=f"wrap_w[{r.name},n{k}]")
    m.addCons(v.x + v.w >= h.x1 - mx * (1 - wrap), name=f"wrap_e[{r.name},n{k}]")
    m.addCons(v.y <= h.y0 + my * (1 - wrap), name=f"wrap_s[{r.name},n{k}]")
    m.addCons(v.y + v.d >= h.y1 - my * (1 - wrap), name=f"wrap_n[{r.name},n{k}]")
    m.addCons(quicksum(sides) + wrap >= 1, name=f"clear[{r.name},n{k}]")
    lm.enclosures.append((wrap, b.area))


def c_overlap(lm: LevelModel) -> None:
    """C_overlap (Eq. 2): each pair is apart along one of four sides."""
    m = lm.model
    mx, my = lm.big_m_x, lm.big_m_y
    for a, b in itertools.combinations(free_rects(lm.spec), 2):
        i, j = lm.rects[a.name], lm.rects[b.name]
        pair = f"{a.name},{b.name}"
        # L, R, B, T: a west of b, east, south, north; set the one they are most apart by.
        side = {s: lm.derive(m.addVar(f"side[{pair},{s}]", vtype="B"),
                             partial(_side_apart, a.name, b.name, k))
                for k, s in enumerate(("L", "R", "B", "T"))}
        m.addCons(i.x + i.w <= j.x + mx * (1 - side["L"]), name=f"left[{pair}]")
        m.addCons(j.x + j.w <= i.x + mx * (1 - side["R"]), name=f"right[{pair}]")
        m.addCons(i.y + i.d <= j.y + my * (1 - side["B"]), name=f"below[{pair}]")
        m.addCons(j.y + j.d <= i.y + my * (1 - side["T"]), name=f"above[{pair}]")
        m.addCons(quicksum(side.values()) >= 1, name=f"overlap[{pair}]")


def c_ratio(lm: LevelModel) -> None:
    """C_ratio (Eq. 7): lo <= long/short <= hi, the binary choosing the orientation."""
    for r in free_rects(lm.spec):
        if r.aspect_ratio is None:
            continue
        v = lm.rects[r.name]
        size = partial(_size, r.name)
        slack = (_slack(lm, f"ratio[{r.name}]", partial(_ratio_miss, size, r.aspect_ratio))
                 if "aspect_ratio" in r.soft else None)
        _either_orientation(lm, v.w, v.d, r.aspect_ratio, tag=r.name, slack=slack, size=size)


def c_pos(lm: LevelModel) -> None:
    """C_pos (Eq. 8): the rectangle covers each of its guide points; soft, it comes
    within a slack of each point on both axes."""
    m = lm.model
    for r in free_rects(lm.spec):
        v = lm.rects[r.name]
        for k, (px, py) in enumerate(r.positions):
            s: Any = (_slack(lm, f"pos[{r.name},{k}]", partial(_point_miss, r.name, (px, py)))
                      if "positions" in r.soft else 0.0)
            m.addCons(v.x <= px + s, name=f"pos_w[{r.name},{k}]")
            m.addCons(v.x + v.w >= px - s, name=f"pos_e[{r.name},{k}]")
            m.addCons(v.y <= py + s, name=f"pos_s[{r.name},{k}]")
            m.addCons(v.y + v.d >= py - s, name=f"pos_n[{r.name},{k}]")


def _edge_choice(lm: LevelModel, r: RectSpec, margin: float | None = None) -> dict[int, Any]:
    """Eq. 9's rho_k: a binary per candidate edge of rectangle `r`, at least one chosen
    (at given boxes, the edge the rectangle is nearest: `_edge_miss`, with the soft
    contact `margin` when soft); a single candidate is simply 1 (no choice to make)."""
    m = lm.model
    if len(r.edges) == 1:
        return {r.edges[0].index: 1.0}
    rho = {e.index: lm.derive(m.addVar(f"rho[{r.name},{e.index}]", vtype="B"),
                              partial(_edge_picked, r, e.index, margin))
           for e in r.edges}
    m.addCons(quicksum(rho.values()) >= 1, name=f"boundary[{r.name}]")
    return rho


def c_boundary(lm: LevelModel) -> None:
    """C_boundary (Eq. 9, all four facings): one whole side of the rectangle lies on
    one of the candidate exterior edges; a binary rho_k per candidate edge. Soft, the
    rectangle comes within a slack of the edge's line and of its span, overlapping
    the span by `SOFT_EDGE_CONTACT` at zero slack."""
    m = lm.model
    for r in free_rects(lm.spec):
        if not r.edges:
            continue
        if "boundary" in r.soft:
            _soft_boundary(lm, r)
            continue
        v = lm.rects[r.name]
        rho = _edge_choice(lm, r)
        for e in r.edges:
            off = 1 - rho[e.index]
            lo, hi = e.span
            along, length, across, extent = (
                (v.x, v.w, v.y, v.d) if e.horizontal else (v.y, v.d, v.x, v.w)
            )
            m_along, m_across = _edge_big_m(lm.spec.region, e)
            tag = f"{r.name},{e.index}"
            m.addCons(along >= lo - m_along * off, name=f"edge_lo[{tag}]")
            m.addCons(along + length <= hi + m_along * off, name=f"edge_hi[{tag}]")
            # The side on the line from both sides: C_inside alone keeps a rectangle on
            # the inner side of an edge on the outline's bounding box only, not of one
            # in a notch (a U's inner wall), where "x <= line" also holds far from it.
            side = across if e.facing in ("south", "west") else across + extent
            m.addCons(side <= e.line + m_across * off, name=f"edge_on[{tag}]")
            m.addCons(side >= e.line - m_across * off, name=f"edge_at[{tag}]")


def _soft_boundary(lm: LevelModel, r: RectSpec) -> None:
    """C_boundary (Eq. 9) with one slack s: across the chosen edge's line the rectangle
    is within s, and along it the rectangle overlaps the edge's span by the contact
    margin less s (the distance `edge_shortfall` measures)."""
    m, v = lm.model, lm.rects[r.name]
    slack = _slack(lm, f"boundary[{r.name}]",
                   lambda boxes: max(0.0, _nearest_edge(r, SOFT_EDGE_CONTACT, boxes)[1]))
    rho = _edge_choice(lm, r, SOFT_EDGE_CONTACT)
    for e in r.edges:
        off = 1 - rho[e.index]
        lo, hi = e.span
        margin = min(SOFT_EDGE_CONTACT, e.length / 2)
        along, length, across, extent = (
            (v.x, v.w, v.y, v.d) if e.horizontal else (v.y, v.d, v.x, v.w)
        )
        m_along, m_across = _edge_big_m(lm.spec.region, e)
        m_along += margin
        tag = f"{r.name},{e.index}"
        m.addCons(along + length >= lo + margin - slack - m_along * off,
                  name=f"edge_lo[{tag}]")
        m.addCons(along <= hi - margin + slack + m_along * off, name=f"edge_hi[{tag}]")
        side = across if e.facing in ("south", "west") else across + extent
        m.addCons(side <= e.line + slack + m_across * off, name=f"edge_on[{tag}]")
        m.addCons(side >= e.line - slack - m_across * off, name=f"edge_at[{tag}]")


def c_adj(lm: LevelModel) -> None:
    """C_adj (Eq. 10) and its any-of form (Eq. 11 generalised to k candidates): the
    two rectangles overlap in x by >= c (theta = 1, a horizontal shared wall) or in y
    by >= c (theta = 0), and touch; C_overlap keeps their interiors apart. Soft, one
    slack s per contact: the overlap along the wall may miss c by s, and the walls may
    stand s apart (the distance `contact_shortfall` measures)."""
    m = lm.model
    mx, my = lm.big_m_x, lm.big_m_y
    for c in lm.spec.contacts:
        # dict.fromkeys: a partner named twice is still one candidate pair.
        pairs = list(dict.fromkeys((a, b) for group in c.partners for b in group for a in c.a))
        # At given boxes: the pair nearest to touching is picked, and the slack is what
        # it misses by (`_contact_miss`).
        s: Any = (_slack(lm, f"adj[{c.name}]",
                         partial(_best_contact, pairs, c.min_contact, slack=True))
                  if c.soft else 0.0)
        if len(pairs) == 1:
            chosen: dict[tuple[str, str], Any] = {pairs[0]: 1.0}
        else:
            chosen = {p: lm.derive(m.addVar(f"adj_pick[{c.name},{p[0]},{p[1]}]", vtype="B"),
                                   partial(_best_contact, pairs, c.min_contact, pick=p))
                      for p in pairs}
            m.addCons(quicksum(chosen.values()) >= 1, name=f"adj_any[{c.name}]")
        for (a, b), pick in chosen.items():
            i, j = lm.rects[a], lm.rects[b]
            tag = f"{c.name},{a},{b}"
            theta = lm.derive(m.addVar(f"theta[{tag}]", vtype="B"),
                              partial(_theta, a, b, c.min_contact))
            off = 1 - pick
            cc = c.min_contact
            m.addCons(i.x <= j.x + j.w - cc * theta + s + (mx + cc) * off,
                      name=f"adj_x1[{tag}]")
            m.addCons(i.x + i.w >= j.x + cc * theta - s - (mx + cc) * off,
                      name=f"adj_x2[{tag}]")
            m.addCons(i.y <= j.y + j.d - cc * (1 - theta) + s + (my + cc) * off,
                      name=f"adj_y1[{tag}]")
            m.addCons(i.y + i.d >= j.y + cc * (1 - theta) - s - (my + cc) * off,
                      name=f"adj_y2[{tag}]")
            # The overlap of two intervals is also bounded by each length: without these
            # a narrow room nested in a wide neighbour's span would pass Eq. 10 with less
            # than c of wall.
            for v, which in ((i, "i"), (j, "j")):
                m.addCons(v.w >= cc * theta - s - cc * off, name=f"adj_wlen[{tag},{which}]")
                m.addCons(v.d >= cc * (1 - theta) - s - cc * off,
                          name=f"adj_dlen[{tag},{which}]")


def c_refine(lm: LevelModel) -> None:
    """C_refine (Eq. 13): each half keeps the parent's extent along the split line and
    its own outer side, and may grow outward by at most delta. Eq. 13 is the vertical
    split (halves side by side); the horizontal one swaps the roles of x and y."""
    m = lm.model
    for r in free_rects(lm.spec):
        if r.refine is None:
            continue
        v, f = lm.rects[r.name], r.refine
        p, delta = f.parent, f.delta
        # (along, along_len) is the axis across the split; (cross, cross_len) runs along it.
        if f.direction == "vertical":
            along, along_len, lo, hi = v.x, v.w, p.x0, p.x1
            cross, cross_len, c_lo, c_hi = v.y, v.d, p.y0, p.y1
        else:
            along, along_len, lo, hi = v.y, v.d, p.y0, p.y1
            cross, cross_len, c_lo, c_hi = v.x, v.w, p.x0, p.x1
        tag = r.name
        m.addCons(cross >= c_lo - delta, name=f"refine_cross_lo[{tag}]")
        m.addCons(cross <= c_lo, name=f"refine_cross_lo2[{tag}]")
        m.addCons(cross + cross_len >= c_hi, name=f"refine_cross_hi[{tag}]")
        m.addCons(cross + cross_len <= c_hi + delta, name=f"refine_cross_hi2[{tag}]")
        # child -1 is a rectangle refined without a split: both outer sides apply.
        if f.child in (0, -1):
            m.addCons(along >= lo - delta, name=f"refine_low[{tag}]")
            m.addCons(along <= lo, name=f"refine_low2[{tag}]")
        if f.child in (1, -1):
            m.addCons(along + along_len >= hi, name=f"refine_high[{tag}]")
            m.addCons(along + along_len <= hi + delta, name=f"refine_high2[{tag}]")


Family = Callable[[LevelModel], None]

#: The builder of each constraint family of `solver.families`, by its symbol.
BUILDERS: dict[str, Family] = {
    "C_inside": c_inside, "C_overlap": c_overlap, "C_size": c_size, "C_ratio": c_ratio,
    "C_pos": c_pos, "C_boundary": c_boundary, "C_adj": c_adj, "C_refine": c_refine,
    "C_envelope": c_envelope,
}
#: Every constraint family of a level, in the paper's order (`solver.families`).
FAMILIES: tuple[Family, ...] = tuple(BUILDERS[f.symbol] for f in REGISTERED)
#: Whether a family constrains anything in a level, for reports; the first three
#: always do.
_IN_SPEC: dict[str, Callable[[LevelSpec], bool]] = {
    "C_inside": lambda spec: True,
    "C_overlap": lambda spec: True,
    "C_size": lambda spec: True,
    "C_ratio": lambda spec: any(r.aspect_ratio for r in spec.rects),
    "C_pos": lambda spec: any(r.positions for r in spec.rects),
    "C_boundary": lambda spec: any(r.edges for r in spec.rects),
    "C_adj": lambda spec: bool(spec.contacts),
    "C_refine": lambda spec: any(r.refine for r in spec.rects),
    "C_envelope": lambda spec: bool(spec.envelopes),
}


def build_level(
    spec: LevelSpec, *, families: Sequence[Family] = FAMILIES, feasibility: bool = False
) -> LevelModel:
    """The level's SCIP model, unsolved. With `feasibility` the objective is zero: SCIP's
    MILP heuristics then find a first layout far sooner than the MIQP does, and that
    layout warm-starts the MIQP."""
    m = Model(f"layout[{spec.name}]")
    m.hideOutput()
    lm = LevelModel(spec=spec, model=m, rects=add_rect_vars(m, spec))
    for family in families:
        family(lm)
        lm.families.append(family.__name__)
    if not feasibility:
        e_objective(lm)
    elif lm.slacks:
        # A first layout of a soft problem: the least violation, Eq. 12 left for later.
        m.setObjective(e_violation(lm), "minimize")
    return lm


def active_families(spec: LevelSpec) -> list[str]:
    """Names of the constraint families that constrain anything in `spec`, for reports."""
    return [f.symbol for f in REGISTERED if _IN_SPEC[f.symbol](spec)]


def _edge_big_m(region: Box, e: Edge) -> tuple[float, float]:
    """Valid M along and across edge `e` for rectangles in `region`: the extent the
    region and the edge span together (an edge may lie outside a sub-region)."""
    lo, hi = e.span
    if e.horizontal:
        along = max(region.x1, hi) - min(region.x0, lo)
        across = max(region.y1, e.line) - min(region.y0, e.line)
    else:
        along = max(region.y1, hi) - min(region.y0, lo)
        across = max(region.x1, e.line) - min(region.x0, e.line)
    return along, across


def _may_intersect(r: RectSpec, region: Box, b: Box) -> bool:
    """False when the rectangle cannot reach `b` whatever its position (it must still
    fit in the region), so the four disjunction binaries would be wasted."""
    if b.width <= EPS or b.depth <= EPS:
        return False
    if r.refine is not None:
        p, delta = r.refine.parent, r.refine.delta
        reach = Box(p.x0 - delta, p.y0 - delta, p.x1 + delta, p.y1 + delta)
        return not (reach.x1 <= b.x0 or reach.x0 >= b.x1 or reach.y1 <= b.y0
                    or reach.y0 >= b.y1)
    return True
