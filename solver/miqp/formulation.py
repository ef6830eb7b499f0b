"""The MIQP of one level (paper Sec. 5.1-5.3), built on SCIP through pyscipopt.

A `LevelSpec` describes what to place: variable rectangles (`RectSpec`) inside a
region given as a bounding box minus constant `blocked` boxes. Level 1 has one
rectangle per room; a refinement level has the two halves of each split room plus
C_refine. Every constraint family is one function below, named after the paper's
symbol and citing its equation; `FAMILIES` lists them once.

Big-M values are per axis (the region's width for x-disjunctions, its depth for y),
the smallest that are valid, and the objective is minimised through one convex
epigraph per rectangle so SCIP can separate gradient cuts term by term.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from pyscipopt import Model, Variable, quicksum

from solver.geometry import EPS, Box, Edge, Notch, bounding_box, encloses
from solver.soft import (
    SOFT_EDGE_CONTACT,
    contact_shortfall,
    edge_shortfall,
    point_shortfall,
    ratio_shortfall,
    size_shortfall,
)

Split = Literal["vertical", "horizontal"]


@dataclass(frozen=True)
class Refine:
    """C_refine (Eq. 13): this rectangle is half `child` (0 = left/bottom, 1 = right/top,
    -1 = the whole parent, unsplit) of `parent`, split by a `direction` line, and may
    grow outward by at most `delta`."""

    parent: Box
    direction: Split
    child: int
    delta: float


@dataclass(frozen=True)
class RectSpec:
    """One variable rectangle of a level and the constraints that apply to it alone."""

    name: str
    room: str
    min_size: tuple[float, float] = (0.0, 0.0)
    max_size: tuple[float, float] = (math.inf, math.inf)
    target: tuple[float, float] | None = None
    aspect_ratio: tuple[float, float] | None = None
    positions: tuple[tuple[float, float], ...] = ()
    edges: tuple[Edge, ...] = ()
    refine: Refine | None = None
    #: A rectangle held at this box: a neighbour that a free rectangle must touch
    #: (C_adj) but that is otherwise settled; it is also among the level's `blocked`.
    fixed: Box | None = None
    #: Soft constraint families of this rectangle (min_size, max_size, aspect_ratio,
    #: positions, boundary): each may be violated at `LevelSpec.violation_weight` per
    #: metre of slack.
    soft: frozenset[str] = frozenset()
    #: Hard lower bounds on width and depth under a soft minimum (or none): a room that
    #: yields to its neighbours still stays a room.
    floor: tuple[float, float] = (0.0, 0.0)
    #: The rectangle may enclose one of the level's notches (`LevelSpec.notches`);
    #: not for a room that must stay one rectangle (`max_rects: 1`).
    may_wrap: bool = True


@dataclass(frozen=True)
class ContactSpec:
    """C_adj (Eq. 10/11): some rectangle of `a` touches some rectangle of one of the
    `partners` groups along at least `min_contact` metres."""

    name: str
    a: tuple[str, ...]
    partners: tuple[tuple[str, ...], ...]
    min_contact: float
    #: The contact may fall short (and the walls stay apart) at a price per metre.
    soft: bool = False

    @property
    def members(self) -> set[str]:
        """Every rectangle the contact names."""
        return set(self.a) | {n for group in self.partners for n in group}


@dataclass(frozen=True)
class EnvelopeSpec:
    """Size and ratio bounds on the bounding box of a room made of several rectangles.

    The rectangles grow from `previous` (their union's bounding box before this level),
    so the true bounding box lies between `previous` and the envelope variables; the
    bounds are imposed conservatively in that sandwich."""

    room: str
    rects: tuple[str, ...]
    #: None at level 1, for a room given several rectangles from the start: the
    #: envelope is then made exact (binaries pick the rectangle on each side).
    previous: Box | None
    max_size: tuple[float, float]
    aspect_ratio: tuple[float, float] | None
    #: Soft families among max_size and aspect_ratio (exact envelopes only).
    soft: frozenset[str] = frozenset()


@dataclass(frozen=True)
class LevelSpec:
    """Everything one MIQP needs."""

    name: str
    region: Box
    blocked: tuple[Box, ...]
    free_area: float
    rects: tuple[RectSpec, ...]
    contacts: tuple[ContactSpec, ...] = ()
    envelopes: tuple[EnvelopeSpec, ...] = ()
    cover_weight: float = 1.0
    size_weight: float = 1.0
    #: Weight of a linear growth term -(d* w + w* d), the tangent of w*d at the aimed
    #: size: it pushes rooms to cover more along their own shape without touching
    #: convexity (0 = Eq. 12 exactly).
    growth_weight: float = 0.0
    #: Price per metre of slack of a soft constraint (`Weights.violation`).
    violation_weight: float = 0.0
    #: Obstacles on the outline a rectangle may enclose (the room wraps around them);
    #: not among `blocked`.
    notches: tuple[Notch, ...] = ()


def free_rects(spec: LevelSpec) -> list[RectSpec]:
    """The rectangles the level places (all but the fixed ones)."""
    return [r for r in spec.rects if r.fixed is None]


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
                slack = _slack(lm, f"min_{name}[{r.name}]")
                m.addCons(var + slack >= lo, name=f"size_min_{name}[{r.name}]")
                m.chgVarLb(var, r.floor[axis])
            else:
                m.chgVarLb(var, max(lo, r.floor[axis]))
            if "max_size" in r.soft and hi < extents[axis]:
                slack = _slack(lm, f"max_{name}[{r.name}]")
                m.addCons(var - slack <= hi, name=f"size_max_{name}[{r.name}]")
                m.chgVarUb(var, extents[axis])
            else:
                m.chgVarUb(var, min(hi, extents[axis]))


def _slack(lm: LevelModel, name: str) -> Variable:
    """A slack variable of a soft constraint (metres), priced in the objective."""
    slack = lm.model.addVar(f"slack[{name}]", lb=0.0, ub=None)
    lm.slacks.append(slack)
    return slack


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
                sides = _clear_sides(lm, r.name, v, b, tag=f"{k}")
                m.addCons(quicksum(sides) >= 1, name=f"clear[{r.name},{k}]")
        for k, n in enumerate(spec.notches):
            _clear_or_wrap(lm, r, v, k, n)


def _clear_sides(lm: LevelModel, name: str, v: RectVars, b: Box, tag: str) -> list[Variable]:
    """Eq. 2 against the constant box `b`: four binaries, each, when set, keeping the
    rectangle west, east, south or north of it. The caller demands one of them (or
    another way out)."""
    m, mx, my = lm.model, lm.big_m_x, lm.big_m_y
    sides = [m.addVar(f"clear[{name},{tag},{s}]", vtype="B") for s in range(4)]
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
    sides = _clear_sides(lm, r.name, v, b, tag=f"n{k}")
    if not r.may_wrap:
        m.addCons(quicksum(sides) >= 1, name=f"clear[{r.name},n{k}]")
        return
    mx, my = lm.big_m_x, lm.big_m_y
    wrap = m.addVar(f"wrap[{r.name},n{k}]", vtype="B")
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
        side = {s: m.addVar(f"side[{pair},{s}]", vtype="B") for s in ("L", "R", "B", "T")}
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
        slack = _slack(lm, f"ratio[{r.name}]") if "aspect_ratio" in r.soft else None
        _either_orientation(lm, v.w, v.d, r.aspect_ratio, tag=r.name, slack=slack)


def _either_orientation(lm: LevelModel, width: Any, depth: Any, ratio: tuple[float, float],
                        *, tag: str, prefix: str = "", slack: Variable | None = None) -> None:
    """lo <= long/short <= hi for a width and depth (variables or expressions), a
    binary sigma choosing which side is the long one (sigma = 1: a vertical room).
    With a `slack` (soft), the long side may miss [lo, hi] x the short side by it."""
    m, (lo, hi) = lm.model, ratio
    s: Any = 0.0 if slack is None else slack
    big = hi * max(lm.big_m_x, lm.big_m_y)
    tall = m.addVar(f"{prefix}tall[{tag}]", vtype="B")
    m.addCons(lo * depth <= width + big * tall + s, name=f"{prefix}ratio_wide_lo[{tag}]")
    m.addCons(hi * depth >= width - big * tall - s, name=f"{prefix}ratio_wide_hi[{tag}]")
    m.addCons(lo * width <= depth + big * (1 - tall) + s,
              name=f"{prefix}ratio_tall_lo[{tag}]")
    m.addCons(hi * width >= depth - big * (1 - tall) - s,
              name=f"{prefix}ratio_tall_hi[{tag}]")


def c_pos(lm: LevelModel) -> None:
    """C_pos (Eq. 8): the rectangle covers each of its guide points; soft, it comes
    within a slack of each point on both axes."""
    m = lm.model
    for r in free_rects(lm.spec):
        v = lm.rects[r.name]
        for k, (px, py) in enumerate(r.positions):
            s: Any = _slack(lm, f"pos[{r.name},{k}]") if "positions" in r.soft else 0.0
            m.addCons(v.x <= px + s, name=f"pos_w[{r.name},{k}]")
            m.addCons(v.x + v.w >= px - s, name=f"pos_e[{r.name},{k}]")
            m.addCons(v.y <= py + s, name=f"pos_s[{r.name},{k}]")
            m.addCons(v.y + v.d >= py - s, name=f"pos_n[{r.name},{k}]")


def _edge_choice(m: Model, r: Any) -> dict[int, Any]:
    """Eq. 9's rho_k: a binary per candidate edge of rectangle `r`, at least one chosen;
    a single candidate is simply 1 (no choice to make)."""
    if len(r.edges) == 1:
        return {r.edges[0].index: 1.0}
    rho = {e.index: m.addVar(f"rho[{r.name},{e.index}]", vtype="B") for e in r.edges}
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
        rho = _edge_choice(m, r)
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
            if e.facing in ("south", "west"):
                m.addCons(across <= e.line + m_across * off, name=f"edge_on[{tag}]")
            else:
                m.addCons(across + extent >= e.line - m_across * off, name=f"edge_on[{tag}]")


def _soft_boundary(lm: LevelModel, r: RectSpec) -> None:
    """C_boundary (Eq. 9) with one slack s: across the chosen edge's line the rectangle
    is within s, and along it the rectangle overlaps the edge's span by the contact
    margin less s (the distance `edge_shortfall` measures)."""
    m, v = lm.model, lm.rects[r.name]
    slack = _slack(lm, f"boundary[{r.name}]")
    rho = _edge_choice(m, r)
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
        if e.facing in ("south", "west"):
            m.addCons(across <= e.line + slack + m_across * off, name=f"edge_on[{tag}]")
        else:
            m.addCons(across + extent >= e.line - slack - m_across * off,
                      name=f"edge_on[{tag}]")


def c_adj(lm: LevelModel) -> None:
    """C_adj (Eq. 10) and its any-of form (Eq. 11 generalised to k candidates): the
    two rectangles overlap in x by >= c (theta = 1, a horizontal shared wall) or in y
    by >= c (theta = 0), and touch; C_overlap keeps their interiors apart. Soft, one
    slack s per contact: the overlap along the wall may miss c by s, and the walls may
    stand s apart (the distance `contact_shortfall` measures)."""
    m = lm.model
    mx, my = lm.big_m_x, lm.big_m_y
    for c in lm.spec.contacts:
        s: Any = _slack(lm, f"adj[{c.name}]") if c.soft else 0.0
        # dict.fromkeys: a partner named twice is still one candidate pair.
        pairs = list(dict.fromkeys((a, b) for group in c.partners for b in group for a in c.a))
        if len(pairs) == 1:
            chosen: dict[tuple[str, str], Any] = {pairs[0]: 1.0}
        else:
            chosen = {p: m.addVar(f"adj_pick[{c.name},{p[0]},{p[1]}]", vtype="B") for p in pairs}
            m.addCons(quicksum(chosen.values()) >= 1, name=f"adj_any[{c.name}]")
        for (a, b), pick in chosen.items():
            i, j = lm.rects[a], lm.rects[b]
            tag = f"{c.name},{a},{b}"
            theta = m.addVar(f"theta[{tag}]", vtype="B")
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
        x0 = m.addVar(f"env_x0[{tag}]", lb=lm.spec.region.x0, ub=e.previous.x0)
        x1 = m.addVar(f"env_x1[{tag}]", lb=e.previous.x1, ub=lm.spec.region.x1)
        y0 = m.addVar(f"env_y0[{tag}]", lb=lm.spec.region.y0, ub=e.previous.y0)
        y1 = m.addVar(f"env_y1[{tag}]", lb=e.previous.y1, ub=lm.spec.region.y1)
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
    """C_size (Eq. 5, the maximum) and C_ratio (Eq. 7) on the exact bounding box of a
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
        edge = box[side] = m.addVar(f"env_{side}[{tag}]", lb=lo, ub=hi)
        picks = [m.addVar(f"env_pick[{tag},{side},{k}]", vtype="B") for k in range(len(vs))]
        m.addCons(quicksum(picks) == 1, name=f"env_one[{tag},{side}]")
        for k, (value, pick) in enumerate(zip(values, picks, strict=True)):
            # outward -1: the box's low side is at or below every rectangle's, and equal
            # to the picked one's; +1 likewise for the high side.
            m.addCons(outward * (edge - value) >= 0, name=f"env_out[{tag},{side},{k}]")
            m.addCons(outward * (edge - value) <= big * (1 - pick),
                      name=f"env_at[{tag},{side},{k}]")
    width, depth = box["x1"] - box["x0"], box["y1"] - box["y0"]
    if "max_size" in e.soft:
        m.addCons(width - _slack(lm, f"env_max_w[{tag}]") <= e.max_size[0],
                  name=f"env_wmax[{tag}]")
        m.addCons(depth - _slack(lm, f"env_max_d[{tag}]") <= e.max_size[1],
                  name=f"env_dmax[{tag}]")
    else:
        m.addCons(width <= e.max_size[0], name=f"env_wmax[{tag}]")
        m.addCons(depth <= e.max_size[1], name=f"env_dmax[{tag}]")
    if e.aspect_ratio is not None:
        slack = _slack(lm, f"env_ratio[{tag}]") if "aspect_ratio" in e.soft else None
        _either_orientation(lm, width, depth, e.aspect_ratio, tag=tag, prefix="env_",
                            slack=slack)


def e_objective(lm: LevelModel) -> None:
    """Eq. 12: lambda_cover * E_cover (Eq. 3) + lambda_size * E_size (Eq. 6).

    SCIP takes no quadratic objective, so each rectangle's term
    lambda_s * ((w - w*)^2 + (d - d*)^2) - lambda_c * w * d is bounded by its own epigraph
    variable. With lambda_s >= lambda_c / 2 each term is convex (Hessian
    [[2 ls, -lc], [-lc, 2 ls]]), which SCIP detects. The constant Area(D) of E_cover is
    the objective offset."""
    m, spec = lm.model, lm.spec
    ls, lc = spec.size_weight, spec.cover_weight
    terms = []
    for r in free_rects(spec):
        v = lm.rects[r.name]
        # The variables' own upper bounds: a soft maximum leaves them the region's.
        w_hi, d_hi = v.w.getUbOriginal(), v.d.getUbOriginal()
        tw, td = _aim(spec, r)
        bonus = spec.growth_weight * (td * w_hi + tw * d_hi)
        z = m.addVar(f"energy[{r.name}]", lb=-lc * w_hi * d_hi - bonus)
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


def e_band_shortfall(
    lm: LevelModel, bands: Mapping[str, tuple[tuple[float, float], tuple[float, float]]]
) -> None:
    """The objective of a first layout under the user's own bounds, when the schedule of
    size windows around the targets (Sec. 5.4) found none: the metres by which the named
    rectangles' widths and depths fall outside their (min, max) `bands`, summed, plus
    the soft constraints' price. A linear stand-in for E_size (Eq. 6) that SCIP's MILP
    heuristics handle as fast as a bare feasibility model. One room that no window can
    hold (a hall that must reach both side walls) makes every window infeasible; without
    this, every other room would then start anywhere within its bounds."""
    m = lm.model
    shortfalls = []
    for r in free_rects(lm.spec):
        if r.name not in bands:
            continue
        v, (lo, hi) = lm.rects[r.name], bands[r.name]
        for axis, var, side in ((0, v.w, "w"), (1, v.d, "d")):
            below = m.addVar(f"band_below[{r.name},{side}]", lb=0.0)
            above = m.addVar(f"band_above[{r.name},{side}]", lb=0.0)
            m.addCons(var + below >= lo[axis], name=f"band_min[{r.name},{side}]")
            m.addCons(var - above <= hi[axis], name=f"band_max[{r.name},{side}]")
            shortfalls += [below, above]
    m.setObjective(quicksum(shortfalls) + e_violation(lm), "minimize")


def e_violation(lm: LevelModel) -> Any:
    """The price of the soft constraints' slacks: `violation_weight` per metre. Linear,
    so Eq. 12 stays convex; the exact-penalty form makes every slack zero whenever the
    rest of the objective gains less than the weight per metre of violation."""
    return lm.spec.violation_weight * quicksum(lm.slacks)


Family = Callable[[LevelModel], None]
#: Every constraint family of a level, in the paper's order.
FAMILIES: tuple[Family, ...] = (c_inside, c_overlap, c_size, c_ratio, c_pos, c_boundary, c_adj,
                                c_refine, c_envelope)


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
    names = ["C_inside", "C_overlap", "C_size"]
    if any(r.aspect_ratio for r in spec.rects):
        names.append("C_ratio")
    if any(r.positions for r in spec.rects):
        names.append("C_pos")
    if any(r.edges for r in spec.rects):
        names.append("C_boundary")
    if spec.contacts:
        names.append("C_adj")
    if any(r.refine for r in spec.rects):
        names.append("C_refine")
    if spec.envelopes:
        names.append("C_envelope")
    return names


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


def _aim(spec: LevelSpec, r: RectSpec) -> tuple[float, float]:
    """The size a rectangle's E_size term pulls toward: its target, or without one the
    middle of its size range, which keeps the objective convex (a bare -w*d term is
    not) while E_cover still pulls the room larger."""
    if r.target is not None:
        return r.target
    w_hi = min(r.max_size[0], spec.region.width)
    d_hi = min(r.max_size[1], spec.region.depth)
    return ((r.min_size[0] + w_hi) / 2, (r.min_size[1] + d_hi) / 2)


def level_objective(spec: LevelSpec, boxes: dict[str, Box]) -> float:
    """Eq. 12 as `e_objective` states it, evaluated on given rectangles."""
    total = spec.cover_weight * spec.free_area
    for r in free_rects(spec):
        b, (tw, td) = boxes[r.name], _aim(spec, r)
        total += spec.size_weight * ((b.width - tw) ** 2 + (b.depth - td) ** 2)
        total -= spec.cover_weight * b.width * b.depth
        total -= spec.growth_weight * (td * b.width + tw * b.depth)
        total += spec.cover_weight * sum(n.obstacle.area for n in spec.notches
                                         if encloses(b, n.obstacle))
    return total + spec.violation_weight * spec_shortfall(spec, boxes)


def spec_shortfall(spec: LevelSpec, boxes: dict[str, Box]) -> float:
    """The total shortfall of the soft constraints of `spec` on given rectangles
    (metres), as the slacks of the MIQP count it (solver/soft.py)."""
    total = 0.0
    for r in free_rects(spec):
        if not r.soft:
            continue
        b = boxes[r.name]
        size = (b.width, b.depth)
        total += size_shortfall(size, r.min_size if "min_size" in r.soft else None,
                                r.max_size if "max_size" in r.soft else None)
        if r.aspect_ratio is not None and "aspect_ratio" in r.soft:
            total += ratio_shortfall(size, r.aspect_ratio)
        if "positions" in r.soft:
            total += sum(point_shortfall([b], p) for p in r.positions)
        if r.edges and "boundary" in r.soft:
            total += edge_shortfall([b], r.edges, SOFT_EDGE_CONTACT)
    for c in spec.contacts:
        if c.soft:
            total += contact_shortfall([boxes[n] for n in c.a],
                                       [[boxes[n] for n in g] for g in c.partners],
                                       c.min_contact)
    for e in spec.envelopes:
        if e.soft and e.previous is None:
            b = bounding_box([boxes[n] for n in e.rects])
            size = (b.width, b.depth)
            if "max_size" in e.soft:
                total += size_shortfall(size, None, e.max_size)
            if e.aspect_ratio is not None and "aspect_ratio" in e.soft:
                total += ratio_shortfall(size, e.aspect_ratio)
    return total


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
