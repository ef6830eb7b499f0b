"""The problem in the guillotine search's numbers: what each room asks (`Needs`), the
floor and its models (`Brief`: the outline's rectangles, or its bounding box with the
parts outside it as voids, or cut to it after the cuts), and one state of the search
(`State`: a slicing tree as a Polish expression, with each room's area and each L's
split)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from floorplan.models import Problem
from floorplan.solver.geometry import Domain, edges_named, rectangles_of
from floorplan.solver.heuristics.level_one import shape_allowance
from floorplan.solver.heuristics.tiling import Fillers

#: (x0, y0, x1, y1): the search's own rectangles, plain tuples for speed.
Rect = tuple[float, float, float, float]

#: The operators of the Polish expression: a vertical cut (left part | right part) and
#: a horizontal one (lower part / upper part). Leaves are numbers >= 0.
VERTICAL, HORIZONTAL = -1, -2

#: Lengths closer than this (m) are equal.
EPS = 1e-7
#: A part of an L narrower than this (m) is a broken shape: below half a metre a part
#: is no use as floor. What the outline cuts off a part may be thinner (the plans have
#: strips of 5-45 cm where a room's cell crossed a notch's corner: the outline's doing,
#: not the search's).
MIN_ARM = 0.5
#: At most this many cells of a plan cut from the outline's bounding box may lie wholly
#: outside the outline (briefs with two or three such cells were those the search
#: found no tiling for, bench/NOTES.md).
FILLERS = 2


@dataclass(frozen=True)
class Needs:
    """What one room asks for, in the search's plain numbers."""

    target: tuple[float, float]
    area: float
    lo: tuple[float, float]
    hi: tuple[float, float]
    ratio: tuple[float, float] | None
    points: tuple[tuple[float, float], ...]
    #: The outline edges the room must run along (C_boundary): (facing, line, lo, hi).
    edges: tuple[tuple[str, float, float, float], ...]
    cap: int
    arm: float


@dataclass(frozen=True)
class Brief:
    ids: tuple[str, ...]
    needs: tuple[Needs, ...]
    #: (room, partners, min_contact) per adjacency (C_adj).
    adjacency: tuple[tuple[int, tuple[int, ...], float], ...]
    floor: tuple[Rect, ...]
    area: float
    #: The parts of `floor` outside the outline, as leaves n + n + k of the tree that no
    #: room takes: a cut plan of the outline's bounding box, the notches among its parts.
    voids: tuple[Rect, ...] = ()
    #: The parts of `floor` outside the outline that rooms lose after the cuts (a plan
    #: cut from a rectangle, then to its outline) ...
    outside: tuple[Rect, ...] = ()
    #: ... and leaves after the voids that no room takes, of the sizes the state says,
    #: which must fall outside the outline (cells of such a plan left outside it).
    fillers: Fillers | None = None


@dataclass
class State:
    """One slicing tree. Leaf r < n is room r's part; leaf n + r its second part, present
    while room r is an L or a T."""

    tokens: list[int]
    #: Each room's area relative to its target's.
    share: list[float]
    #: An L room's first part's share of its area.
    split: list[float]
    #: The fillers' areas.
    holes: list[float] = field(default_factory=list)

    def copy(self) -> State:
        return State(self.tokens[:], self.share[:], self.split[:], self.holes[:])


def make_brief(problem: Problem, domain: Domain) -> Brief:
    """The problem in the search's numbers, the floor as the outline's rectangles."""
    index = {r.id: k for k, r in enumerate(problem.rooms)}
    needs = []
    for room in problem.rooms:
        assert room.target_size is not None
        tw, td = room.target_size
        edges = tuple((e.facing, e.line, *e.span)
                      for e in edges_named(problem, domain.edges, room.boundary))
        lo = room.min_size or (0.0, 0.0)
        hi = room.max_size or (math.inf, math.inf)
        needs.append(Needs((tw, td), tw * td, (lo[0], lo[1]), (hi[0], hi[1]),
                            room.aspect_ratio, tuple(room.positions), edges,
                            shape_allowance(room), min(MIN_ARM, min(lo) or MIN_ARM)))
    adjacency = tuple((index[a.a], tuple(index[b] for b in a.partners if b in index),
                       a.min_contact) for a in problem.adjacency if a.a in index)
    floor = tuple((b.x0, b.y0, b.x1, b.y1) for b in rectangles_of(domain.free))
    return Brief(tuple(index), tuple(needs), adjacency, floor, float(domain.free.area))


def boxed_models(brief: Brief, domain: Domain) -> list[Brief]:
    """For an outline that is not a rectangle, `brief` with the floor as its bounding
    box: the parts outside the outline as voids, and the box cut as a plan drawn on a
    rectangle and then cut to its outline (the rooms lose what lies outside it, one
    fillers stand for the cells left wholly outside). None for a rectangle's."""
    box = domain.bbox
    beyond = box.to_polygon().difference(domain.free)
    outside = tuple((b.x0, b.y0, b.x1, b.y1) for b in rectangles_of(beyond))
    if not outside:
        return []
    parts = [part.bounds for part in getattr(beyond, "geoms", [beyond])]
    fillers = Fillers(FILLERS, (max(p[2] - p[0] for p in parts), max(p[3] - p[1] for p in parts)),
                      beyond.area, tuple((p[2] - p[0], p[3] - p[1]) for p in parts))
    whole = ((box.x0, box.y0, box.x1, box.y1),)
    return [replace(brief, floor=whole, voids=outside),
            replace(brief, floor=whole, area=box.area, outside=outside, fillers=fillers)]
