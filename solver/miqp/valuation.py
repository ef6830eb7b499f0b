"""The values a level model's variables take at given boxes, in closed form: how far a
rectangle lies from a bound, which side of another it clears, its orientation, how far
it misses a point, an edge or a contact, and the sides of a room's bounding box. The
families of `formulation` register these with each variable they create
(`LevelModel.derive`), so that a start is a full solution without a SCIP solve. Pure
functions of the boxes: nothing here touches SCIP."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

from floorplan.solver.geometry import Box, Edge, bounding_box
from floorplan.solver.miqp.model import Boxes
from floorplan.solver.miqp.spec import RectSpec

#: A constraint of a start counts as holding when violated by no more than this,
#: relative to the coordinates compared (at least 1 m): SCIP's feasibility tolerance,
#: within which the boxes of its own solutions satisfy the constraints.
START_TOL = 1e-6


def _below(name: str, axis: int, lo: float, boxes: Boxes) -> float:
    """How far the rectangle's width (axis 0) or depth falls short of `lo`."""
    return max(0.0, lo - _extent(boxes[name], axis))


def _above(name: str, axis: int, hi: float, boxes: Boxes) -> float:
    """How far the rectangle's width (axis 0) or depth exceeds `hi`."""
    return max(0.0, _extent(boxes[name], axis) - hi)


def _extent(b: Box, axis: int) -> float:
    return b.width if axis == 0 else b.depth


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


def _side_apart(a: str, b: str, side: int, boxes: Boxes) -> float:
    """1 when `side` is the one along which rectangle `a` is farthest apart from `b`."""
    return float(_apart(boxes[a], boxes[b]).side == side)


Size = Callable[[Boxes], tuple[float, float]]


def _size(name: str, boxes: Boxes) -> tuple[float, float]:
    b = boxes[name]
    return b.width, b.depth


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


def _point_miss(name: str, point: tuple[float, float], boxes: Boxes) -> float:
    """How far the rectangle is from a guide point along the farther axis (the least
    slack of a soft C_pos)."""
    b, (px, py) = boxes[name], point
    return max(0.0, b.x0 - px, px - b.x1, b.y0 - py, py - b.y1)


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
