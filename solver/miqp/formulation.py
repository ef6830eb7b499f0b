"""The MIQP of one level (paper Sec. 5.1-5.3), built on SCIP through pyscipopt.

A `LevelSpec` describes what to place: variable rectangles (`RectSpec`) inside a
region given as a bounding box minus constant `blocked` boxes. Level 1 has one
rectangle per room; a refinement level has the two halves of each split room plus
C_refine. Every constraint family is one function below, named after the paper's
symbol and citing its equation; `solver.families` lists them once.

Big-M values are per axis (the region's width for x-disjunctions, its depth for y),
the smallest that are valid, and the objective is minimised through one convex
epigraph per rectangle so SCIP can separate gradient cuts term by term.

Every variable other than the rectangles' x, y, w, d is registered, where it is
created, with how its value follows from the rectangles' boxes (`LevelModel.derive`):
a binary takes a value that satisfies its big-M constraints whenever the boxes satisfy
the family, a slack the least value its constraints allow. A start is then a full
solution computed in closed form (`scip_run.add_start`), not a SCIP solve.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any, NamedTuple

from pyscipopt import Model, Variable, quicksum

from floorplan.solver.families import FAMILIES as REGISTERED
from floorplan.solver.geometry import EPS, Box, Edge, Notch, bounding_box
from floorplan.solver.miqp.model import Boxes, LevelModel, RectVars, Valuation, add_rect_vars
from floorplan.solver.miqp.objective import e_objective, e_violation
from floorplan.solver.miqp.spec import EnvelopeSpec, LevelSpec, RectSpec, free_rects
from floorplan.solver.soft import (
    SOFT_EDGE_CONTACT,
)

#: A constraint of a start counts as holding when violated by no more than this,
#: relative to the coordinates compared (at least 1 m): SCIP's feasibility tolerance,
#: within which the boxes of its own solutions satisfy the constraints.
START_TOL = 1e-6


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


def _slack(lm: LevelModel, name: str, value: Valuation) -> Variable:
    """A slack variable of a soft constraint (metres), priced in the objective; `value`
    is its least value that satisfies the constraint at given boxes."""
    slack = lm.derive(lm.model.addVar(f"slack[{name}]", lb=0.0, ub=None), value)
    lm.slacks.append(slack)
    return slack


def _below(name: str, axis: int, lo: float, boxes: Boxes) -> float:
    """How far the rectangle's width (axis 0) or depth falls short of `lo`."""
    return max(0.0, lo - _extent(boxes[name], axis))


def _above(name: str, axis: int, hi: float, boxes: Boxes) -> float:
    """How far the rectangle's width (axis 0) or depth exceeds `hi`."""
    return max(0.0, _extent(boxes[name], axis) - hi)


def _extent(b: Box, axis: int) -> float:
    return b.width if axis == 0 else b.depth


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


class _Apart(NamedTuple):
    """Where one rectangle stands against another (`_apart`)."""

    side: int  # of the other: 0 west, 1 east, 2 south, 3 north
    gap: float  # how far beyond it; negative: they overlap along every side
    clear: bool  # the gap counts as no overlap, within SCIP's tolerance (`START_TOL`)


def _apart(a: Box, b: Box) -> _Apart:
    """The side of `b` that `a` is farthest beyond (the first such on a tie): the side
    whose big-M disjunct (Eq. 2) holds best."""
    gaps = (b.x0 - a.x1, a.x0 - b.x1, b.y0 - a.y1, a.y0 - b.y1)
    side = max(range(4), key=gaps.__getitem__)
    scale = max(1.0, abs(a.x0), abs(a.x1), abs(a.y0), abs(a.y1))
    return _Apart(side, gaps[side], gaps[side] >= -START_TOL * scale)


def _clear_side(name: str, b: Box, side: int, wraps: bool, boxes: Boxes) -> float:
    """1 for the side of `b` the rectangle is farthest beyond; with `wraps`, 0 for
    every side when none is clear (the rectangle wraps the notch instead)."""
    apart = _apart(boxes[name], b)
    return float(apart.side == side and (not wraps or apart.clear))


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


def _side_apart(a: str, b: str, side: int, boxes: Boxes) -> float:
    """1 when `side` is the one along which rectangle `a` is farthest apart from `b`."""
    return float(_apart(boxes[a], boxes[b]).side == side)


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


Size = Callable[[Boxes], tuple[float, float]]


def _size(name: str, boxes: Boxes) -> tuple[float, float]:
    b = boxes[name]
    return b.width, b.depth


def _either_orientation(lm: LevelModel, width: Any, depth: Any, ratio: tuple[float, float],
                        *, tag: str, size: Size, prefix: str = "",
                        slack: Variable | None = None) -> None:
    """lo <= long/short <= hi for a width and depth (variables or expressions, whose
    values at given boxes `size` gives), a binary sigma choosing which side is the long
    one (sigma = 1: a vertical room). With a `slack` (soft), the long side may miss
    [lo, hi] x the short side by it."""
    m, (lo, hi) = lm.model, ratio
    s: Any = 0.0 if slack is None else slack
    big = hi * max(lm.big_m_x, lm.big_m_y)
    tall = lm.derive(m.addVar(f"{prefix}tall[{tag}]", vtype="B"),
                     lambda boxes: _orientation(*size(boxes), ratio)[0])
    m.addCons(lo * depth <= width + big * tall + s, name=f"{prefix}ratio_wide_lo[{tag}]")
    m.addCons(hi * depth >= width - big * tall - s, name=f"{prefix}ratio_wide_hi[{tag}]")
    m.addCons(lo * width <= depth + big * (1 - tall) + s,
              name=f"{prefix}ratio_tall_lo[{tag}]")
    m.addCons(hi * width >= depth - big * (1 - tall) - s,
              name=f"{prefix}ratio_tall_hi[{tag}]")


def _orientation(w: float, d: float, ratio: tuple[float, float]) -> tuple[float, float]:
    """sigma for a width and depth (1: read as tall), the orientation whose constraints
    need the least slack, and that slack (0 when the ratio holds either way round)."""
    lo, hi = ratio
    wide = max(0.0, lo * d - w, w - hi * d)
    tall = max(0.0, lo * w - d, d - hi * w)
    if tall < wide or (tall == wide and d > w):
        return 1.0, tall
    return 0.0, wide


def _ratio_miss(size: Size, ratio: tuple[float, float], boxes: Boxes) -> float:
    """The least slack of a soft ratio (`_either_orientation`)."""
    return _orientation(*size(boxes), ratio)[1]


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


def _point_miss(name: str, point: tuple[float, float], boxes: Boxes) -> float:
    """How far the rectangle is from a guide point along the farther axis (the least
    slack of a soft C_pos)."""
    b, (px, py) = boxes[name], point
    return max(0.0, b.x0 - px, px - b.x1, b.y0 - py, py - b.y1)


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


def _edge_miss(b: Box, e: Edge, margin: float | None) -> float:
    """How far rectangle `b` is from lying on edge `e` as C_boundary's constraints for
    that edge say (the least slack they need; <= 0 when they hold): hard (`margin` None),
    its side on the line and within the span; soft, its side within the slack of the
    line and overlapping the span by the contact margin less the slack."""
    lo, hi = e.span
    a0, a1 = (b.x0, b.x1) if e.horizontal else (b.y0, b.y1)
    side = ((b.y0 if e.horizontal else b.x0) if e.facing in ("south", "west")
            else (b.y1 if e.horizontal else b.x1))
    if margin is None:
        return max(lo - a0, a1 - hi, abs(side - e.line))
    margin = min(margin, e.length / 2)
    return max(lo + margin - a1, a0 - (hi - margin), abs(side - e.line))


def _nearest_edge(r: RectSpec, margin: float | None, boxes: Boxes) -> tuple[int, float]:
    """The candidate edge (its index) the rectangle misses least, the first on a tie,
    and by how much."""
    b = boxes[r.name]
    misses = [(_edge_miss(b, e, margin), k) for k, e in enumerate(r.edges)]
    miss, k = min(misses)
    return r.edges[k].index, miss


def _edge_picked(r: RectSpec, index: int, margin: float | None, boxes: Boxes) -> float:
    """rho_k: 1 for the edge the rectangle misses least."""
    return float(_nearest_edge(r, margin, boxes)[0] == index)


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


def _contact_miss(i: Box, j: Box, cc: float) -> tuple[float, float]:
    """theta for a pair (1: a horizontal shared wall, overlapping in x by >= cc), the
    orientation whose C_adj constraints need the least slack, and that slack (<= 0
    when they hold): the contact missing along the wall, or the gap across it."""
    horizontal = max(cc - (i.x1 - j.x0), cc - (j.x1 - i.x0), cc - i.width, cc - j.width,
                     i.y0 - j.y1, j.y0 - i.y1)
    vertical = max(cc - (i.y1 - j.y0), cc - (j.y1 - i.y0), cc - i.depth, cc - j.depth,
                   i.x0 - j.x1, j.x0 - i.x1)
    return (1.0, horizontal) if horizontal <= vertical else (0.0, vertical)


def _theta(a: str, b: str, cc: float, boxes: Boxes) -> float:
    return _contact_miss(boxes[a], boxes[b], cc)[0]


def _best_contact(pairs: Sequence[tuple[str, str]], cc: float, boxes: Boxes, *,
                  pick: tuple[str, str] | None = None, slack: bool = False) -> float:
    """Of a contact's candidate `pairs`, the one nearest to touching (the first on a
    tie): with `slack`, what it misses by (at least 0); else 1 when it is `pick`."""
    miss, best = min((_contact_miss(boxes[a], boxes[b], cc)[1], k)
                     for k, (a, b) in enumerate(pairs))
    if slack:
        return max(0.0, miss)
    return float(pairs[best] == pick)


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


def c_envelope(lm: LevelModel) -> None:
    """C_size (Eq. 5) and C_ratio (Eq. 7) on the bounding box of a room of several
    rectangles. Envelope variables bound the true box from outside; the previous box
    bounds it from inside, so the inequalities below are sufficient, never optimistic."""
    m = lm.model
    for e in lm.spec.envelopes:
        if e.previous is None:
            _exact_envelope(lm, e)
            continue
        vs = [lm.rects[n] for n in e.rects]
        tag = e.room
        region, prev = lm.spec.region, e.previous
        # At given boxes: their bounding box, within the variables' bounds (any value
        # between it and the previous box satisfies the sandwich; the tightest is best).
        x0 = lm.derive(m.addVar(f"env_x0[{tag}]", lb=region.x0, ub=prev.x0),
                       partial(_envelope_side, e.rects, "x0", region.x0, prev.x0))
        x1 = lm.derive(m.addVar(f"env_x1[{tag}]", lb=prev.x1, ub=region.x1),
                       partial(_envelope_side, e.rects, "x1", prev.x1, region.x1))
        y0 = lm.derive(m.addVar(f"env_y0[{tag}]", lb=region.y0, ub=prev.y0),
                       partial(_envelope_side, e.rects, "y0", region.y0, prev.y0))
        y1 = lm.derive(m.addVar(f"env_y1[{tag}]", lb=prev.y1, ub=region.y1),
                       partial(_envelope_side, e.rects, "y1", prev.y1, region.y1))
        for k, v in enumerate(vs):
            m.addCons(x0 <= v.x, name=f"env_w[{tag},{k}]")
            m.addCons(x1 >= v.x + v.w, name=f"env_e[{tag},{k}]")
            m.addCons(y0 <= v.y, name=f"env_s[{tag},{k}]")
            m.addCons(y1 >= v.y + v.d, name=f"env_n[{tag},{k}]")
        m.addCons(x1 - x0 <= e.max_size[0], name=f"env_wmax[{tag}]")
        m.addCons(y1 - y0 <= e.max_size[1], name=f"env_dmax[{tag}]")
        if e.aspect_ratio is not None:
            lo, hi = e.aspect_ratio
            w0, d0 = e.previous.width, e.previous.depth
            # Keep the orientation the room already has: long side / short side stays
            # within [lo, hi] whatever the true box is inside the sandwich.
            if w0 >= d0:
                m.addCons(x1 - x0 <= hi * d0, name=f"env_ratio_hi[{tag}]")
                m.addCons(lo * (y1 - y0) <= w0, name=f"env_ratio_lo[{tag}]")
            else:
                m.addCons(y1 - y0 <= hi * w0, name=f"env_ratio_hi[{tag}]")
                m.addCons(lo * (x1 - x0) <= d0, name=f"env_ratio_lo[{tag}]")


def _exact_envelope(lm: LevelModel, e: EnvelopeSpec) -> None:
    """C_size (Eq. 5), C_ratio (Eq. 7) and C_pos (Eq. 8) on the exact bounding box of a
    room of several free rectangles: each side of the box is the extreme side of one
    rectangle, picked by a binary, and a binary picks the orientation as in c_ratio."""
    m, region = lm.model, lm.spec.region
    vs = [lm.rects[n] for n in e.rects]
    tag = e.room
    mx, my = lm.big_m_x, lm.big_m_y
    sides = {
        "x0": ([v.x for v in vs], region.x0, region.x1, mx, -1),
        "x1": ([v.x + v.w for v in vs], region.x0, region.x1, mx, 1),
        "y0": ([v.y for v in vs], region.y0, region.y1, my, -1),
        "y1": ([v.y + v.d for v in vs], region.y0, region.y1, my, 1),
    }
    box: dict[str, Variable] = {}
    for side, (values, lo, hi, big, outward) in sides.items():
        # At given boxes: the bounding box's side, and the first rectangle on it.
        edge = box[side] = lm.derive(m.addVar(f"env_{side}[{tag}]", lb=lo, ub=hi),
                                     partial(_envelope_side, e.rects, side, lo, hi))
        picks = [lm.derive(m.addVar(f"env_pick[{tag},{side},{k}]", vtype="B"),
                           partial(_envelope_pick, e.rects, side, k))
                 for k in range(len(vs))]
        m.addCons(quicksum(picks) == 1, name=f"env_one[{tag},{side}]")
        for k, (value, pick) in enumerate(zip(values, picks, strict=True)):
            # outward -1: the box's low side is at or below every rectangle's, and equal
            # to the picked one's; +1 likewise for the high side.
            m.addCons(outward * (edge - value) >= 0, name=f"env_out[{tag},{side},{k}]")
            m.addCons(outward * (edge - value) <= big * (1 - pick),
                      name=f"env_at[{tag},{side},{k}]")
    for k, (px, py) in enumerate(e.positions):
        # C_pos (Eq. 8) on the room: one rectangle, picked by a binary, covers the point.
        # At given boxes: the first rectangle nearest to the point.
        picks = [lm.derive(m.addVar(f"env_pos[{tag},{k},{j}]", vtype="B"),
                           partial(_covering, e.rects, (px, py), j))
                 for j in range(len(vs))]
        m.addCons(quicksum(picks) == 1, name=f"env_pos_one[{tag},{k}]")
        for j, (v, pick) in enumerate(zip(vs, picks, strict=True)):
            off = 1 - pick
            m.addCons(v.x <= px + mx * off, name=f"env_pos_w[{tag},{k},{j}]")
            m.addCons(v.x + v.w >= px - mx * off, name=f"env_pos_e[{tag},{k},{j}]")
            m.addCons(v.y <= py + my * off, name=f"env_pos_s[{tag},{k},{j}]")
            m.addCons(v.y + v.d >= py - my * off, name=f"env_pos_n[{tag},{k},{j}]")
    width, depth = box["x1"] - box["x0"], box["y1"] - box["y0"]
    size = partial(_envelope_size, e.rects)
    if "min_size" in e.soft:
        m.addCons(width + _slack(lm, f"env_min_w[{tag}]",
                                 partial(_envelope_miss, size, 0, e.min_size[0], -1))
                  >= e.min_size[0], name=f"env_wmin[{tag}]")
        m.addCons(depth + _slack(lm, f"env_min_d[{tag}]",
                                 partial(_envelope_miss, size, 1, e.min_size[1], -1))
                  >= e.min_size[1], name=f"env_dmin[{tag}]")
    else:
        m.addCons(width >= e.min_size[0], name=f"env_wmin[{tag}]")
        m.addCons(depth >= e.min_size[1], name=f"env_dmin[{tag}]")
    if "max_size" in e.soft:
        m.addCons(width - _slack(lm, f"env_max_w[{tag}]",
                                 partial(_envelope_miss, size, 0, e.max_size[0], 1))
                  <= e.max_size[0], name=f"env_wmax[{tag}]")
        m.addCons(depth - _slack(lm, f"env_max_d[{tag}]",
                                 partial(_envelope_miss, size, 1, e.max_size[1], 1))
                  <= e.max_size[1], name=f"env_dmax[{tag}]")
    else:
        m.addCons(width <= e.max_size[0], name=f"env_wmax[{tag}]")
        m.addCons(depth <= e.max_size[1], name=f"env_dmax[{tag}]")
    if e.aspect_ratio is not None:
        slack = (_slack(lm, f"env_ratio[{tag}]", partial(_ratio_miss, size, e.aspect_ratio))
                 if "aspect_ratio" in e.soft else None)
        _either_orientation(lm, width, depth, e.aspect_ratio, tag=tag, prefix="env_",
                            slack=slack, size=size)


#: Each side of a bounding box: the rectangles' coordinate it is the extreme of, and
#: whether that extreme is the least (the low sides) or the greatest.
_SIDES: dict[str, tuple[Callable[[Box], float], bool]] = {
    "x0": (lambda b: b.x0, True), "x1": (lambda b: b.x1, False),
    "y0": (lambda b: b.y0, True), "y1": (lambda b: b.y1, False),
}


def _envelope_side(names: Sequence[str], side: str, lo: float, hi: float,
                   boxes: Boxes) -> float:
    """A side of the rectangles' bounding box, within [lo, hi]."""
    coordinate, least = _SIDES[side]
    values = [coordinate(boxes[n]) for n in names]
    return min(max(min(values) if least else max(values), lo), hi)


def _envelope_pick(names: Sequence[str], side: str, k: int, boxes: Boxes) -> float:
    """1 when rectangle `k` is the first whose side is the bounding box's `side`."""
    coordinate, least = _SIDES[side]
    values = [coordinate(boxes[n]) for n in names]
    extreme = (min if least else max)(range(len(values)), key=values.__getitem__)
    return float(extreme == k)


def _envelope_size(names: Sequence[str], boxes: Boxes) -> tuple[float, float]:
    b = bounding_box([boxes[n] for n in names])
    return b.width, b.depth


def _envelope_miss(size: Size, axis: int, bound: float, sense: int, boxes: Boxes) -> float:
    """How far the bounding box's width (axis 0) or depth is below a minimum
    (`sense` -1) or above a maximum (+1): the least slack."""
    return max(0.0, sense * (size(boxes)[axis] - bound))


def _covering(names: Sequence[str], point: tuple[float, float], k: int,
              boxes: Boxes) -> float:
    """1 when rectangle `k` is the first of `names` nearest to the point (covering it
    when any does)."""
    misses = [_point_miss(n, point, boxes) for n in names]
    return float(min(range(len(misses)), key=misses.__getitem__) == k)


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
