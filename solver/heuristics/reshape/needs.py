"""What the brief asks of one room's shape as the reshaping changes it (`RoomNeeds`:
its corners, arms, exterior walls; `shape_ok`; `keeps_demands` for its adjacencies), and
what a shape costs (`shape_cost`: E_size of its bounding box, the relative area error and a
price per corner)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from shapely.geometry import LineString, Point, Polygon

from floorplan.models import Problem, Room
from floorplan.solver.geometry import (
    Box,
    Domain,
    GeometryError,
    contact_length,
    edges_named,
    room_polygon,
)
from floorplan.solver.heuristics.level_one import shape_allowance
from floorplan.solver.soft import ratio_shortfall, size_shortfall

#: A room's arms stay at least this thick (metres), or as thick as its minimum size
#: allows when that is less: a thinner arm is no floor anyone can use.
MIN_ARM = 0.9
#: Weight of the relative area error, against E_size's 1 per square metre of dimension
#: error. Linear, not squared: the floor the Ls' notches leave is cheapest in one large
#: room, as the plans have it, where a squared error spreads it over every room (56
#: planted briefs: linear 5, 10 and 20 against squared 30; bench/NOTES.md, 'The
#: reshaping's area error, linear').
AREA_WEIGHT = 10.0
#: Price of each corner of a room beyond four (in m² of Eq. 6).
CORNER_WEIGHT = 0.05
#: Size errors and shortfalls are compared to this tolerance (m² and m).
TOL = 1e-6

#: A rectangle as (x0, y0, x1, y1): the cheap arithmetic of refusing a strip unbuilt.
Rect = tuple[float, float, float, float]


@dataclass(frozen=True)
class RoomNeeds:
    """What the brief asks of one room, for checking a changed shape quickly."""

    room: Room
    corners: int
    arm: float
    edges: tuple[LineString, ...]


def room_needs(problem: Problem, domain: Domain, room: Room, shape: Polygon | None) -> RoomNeeds:
    allowed = shape_allowance(room)
    # A rectangle has 4 corners, each further rectangle adds 2 (L: 6, T or U: 8); a room
    # that already has more (it wraps an obstacle) may keep them.
    corners = 2 + 2 * allowed
    if shape is not None:
        corners = max(corners, corner_count(shape))
    short = min(room.min_size) if room.min_size else MIN_ARM
    edges = tuple(LineString([e.start, e.end])
                  for e in edges_named(problem, domain.edges, room.boundary))
    return RoomNeeds(room, corners, min(MIN_ARM, short), edges)


def shape_of(boxes: Sequence[Box]) -> Polygon | None:
    """A room's rectangles as one polygon without holes, or None."""
    try:
        shape = room_polygon(boxes)
    except GeometryError:
        return None
    return None if shape.interiors else shape


def corner_count(shape: Polygon) -> int:
    return len(shape.exterior.coords) - 1


def shape_ok(needs: RoomNeeds, new: Polygon, old: Polygon) -> bool:
    """The room's own constraints on its changed shape: no more corners than it may
    have, arms thick enough, and size, ratio, guide points and exterior wall no worse
    than before."""
    if corner_count(new) > needs.corners:
        return False
    if not _thick(new, needs.arm):
        return False
    return _shortfall(needs, new) <= _shortfall(needs, old) + TOL


def _thick(shape: Polygon, arm: float) -> bool:
    """No part of `shape` thinner than `arm` (a square opening loses nothing)."""
    half = arm / 2 - 1e-4
    opened = shape.buffer(-half, join_style="mitre").buffer(half, join_style="mitre")
    return opened.area >= shape.area - 1e-3


def _shortfall(needs: RoomNeeds, shape: Polygon) -> float:
    """How far (metres) the shape misses its room's size, ratio, guide points and
    exterior walls (a missed wall counts 1)."""
    room = needs.room
    x0, y0, x1, y1 = shape.bounds
    size = (x1 - x0, y1 - y0)
    miss = size_shortfall(size, room.min_size, room.max_size)
    if room.aspect_ratio:
        miss += ratio_shortfall(size, room.aspect_ratio)
    miss += sum(shape.distance(Point(p)) for p in room.positions)
    if needs.edges and not any(shape.boundary.intersection(e).length > 1e-3
                               for e in needs.edges):
        miss += 1.0
    return miss


def keeps_demands(adjacency: Sequence[tuple[str, Sequence[str], float]],
                   by_room: Mapping[str, list[int]], before: Mapping[str, Polygon],
                   after: Mapping[str, Polygon], moved: tuple[str, ...]) -> bool:
    """Every adjacency of the changed rooms keeps its contact, or falls short by
    no more than before."""
    for k in {k for r in moved for k in by_room.get(r, ())}:
        a, partners, contact = adjacency[k]
        if _contact_miss(before, a, partners, contact) + TOL < _contact_miss(
                after, a, partners, contact):
            return False
    return True


def _contact_miss(state: Mapping[str, Polygon], a: str, partners: Sequence[str],
                  contact: float) -> float:
    if a not in state:
        return math.inf
    # The longest straight stretch: the checker's contact, and where the door goes.
    best = max((contact_length(state[a], state[p]) for p in partners if p in state),
               default=0.0)
    return max(0.0, contact - best)


@dataclass(frozen=True)
class Cost:
    size: float  # the Eq. 12 term: E_size (Eq. 6) of the bounding box, or a gap's cover
    total: float  # plus the area and corner terms


def shape_cost(needs: RoomNeeds | None, shape: Polygon) -> Cost:
    """E_size of the room's bounding box, and the total the annealing lowers: that,
    the relative area error (`AREA_WEIGHT`) and a small price per corner
    beyond a rectangle's (`CORNER_WEIGHT`): of two shapes equally near the targets,
    the simpler."""
    corners = CORNER_WEIGHT * (corner_count(shape) - 4)
    if needs is None or needs.room.target_size is None:
        return Cost(0.0, corners)
    size, area = size_terms(needs.room.target_size, shape.bounds, shape.area)
    return Cost(size, size + area + corners)


def cost_floor(needs: RoomNeeds | None, bounds: Rect | None, area: float) -> float:
    """The least `shape_cost(needs, shape).total` of a shape with these bounds and area (its
    corners' price is at least 0)."""
    if needs is None or needs.room.target_size is None or bounds is None:
        return 0.0
    return sum(size_terms(needs.room.target_size, bounds, area))


def size_terms(target: tuple[float, float], bounds: Rect, area: float
                ) -> tuple[float, float]:
    """E_size of a room with these bounds, and its weighted relative area error."""
    tw, td = target
    x0, y0, x1, y1 = bounds
    size = (x1 - x0 - tw) ** 2 + (y1 - y0 - td) ** 2
    return size, AREA_WEIGHT * abs(area - tw * td) / max(tw * td, TOL)
