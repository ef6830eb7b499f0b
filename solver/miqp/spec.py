"""What a level's MIQP places (paper Sec. 5.1-5.3), as plain data that pickles: variable
rectangles (`RectSpec`) in a region, the contacts and envelopes between them, and Eq. 12
and the soft shortfalls evaluated on given boxes, without SCIP."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from floorplan.solver.geometry import Box, Edge, Notch, bounding_box, encloses
from floorplan.solver.soft import (
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
    #: Soft families among min_size, max_size and aspect_ratio (exact envelopes only).
    soft: frozenset[str] = frozenset()
    #: The room's minimum size, on its bounding box (exact envelopes only: a grown box
    #: is never smaller than the previous one).
    min_size: tuple[float, float] = (0.0, 0.0)
    #: Guide points some rectangle of the room covers, whichever (exact envelopes only:
    #: at later levels a point stays covered, as rectangles only grow).
    positions: tuple[tuple[float, float], ...] = ()


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


def aim(spec: LevelSpec, r: RectSpec) -> tuple[float, float]:
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
        b, (tw, td) = boxes[r.name], aim(spec, r)
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
            if "min_size" in e.soft:
                total += size_shortfall(size, e.min_size, None)
            if "max_size" in e.soft:
                total += size_shortfall(size, None, e.max_size)
            if e.aspect_ratio is not None and "aspect_ratio" in e.soft:
                total += ratio_shortfall(size, e.aspect_ratio)
    return total
