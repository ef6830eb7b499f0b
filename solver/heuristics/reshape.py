"""Reshaping a covering layout (issue 19; the size-error trigger of paper Sec. 5.3 done
by moving walls): floor passes from a room to a neighbour across the wall they share,
so a room stretched to cover the outline gives back what a neighbour needs, and either
may become an L or a T on the way, as rooms of real plans do.

The refinement levels only grow rooms (C_refine, Eq. 13), so a room the first layout
made too large stays too large. Here a step moves one strip of floor between two rooms
(or a room and a gap), swaps two rooms' floors, or sets a room into a corner of another
while a neighbour takes its floor (`_nest`), and is kept when the annealing says so
(three runs from the same layout, the best kept): it may not break a constraint of the
brief more than before, and the layout returned is the best one seen that covers the
floor and has no higher Eq. 12 than the one given. What the annealing lowers is E_size
(Eq. 6, on bounding boxes) plus the relative area error (`AREA_WEIGHT`: a room's
bounding box at its target says nothing of the floor inside it) and a small price per
corner (`CORNER_WEIGHT`: of two shapes equally near the targets, the simpler).

Plain geometry on shapely polygons: no SCIP. Every candidate strip lies across one
straight stretch of a shared wall, as deep as a target or an existing corner asks."""

from __future__ import annotations

import functools
import math
import random
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import LineString, Point, Polygon, box
from shapely.geometry.base import BaseGeometry

from floorplan.models import Problem, Room
from floorplan.solver.geometry import (
    GRID,
    Box,
    Domain,
    GeometryError,
    contact_length,
    edges_named,
    rectangles_of,
    room_polygon,
    shared_wall_length,
    straight_stretches,
)
from floorplan.solver.heuristics.level_one import shape_allowance
from floorplan.solver.soft import ratio_shortfall, size_shortfall

#: A room's arms stay at least this thick (metres), or as thick as its minimum size
#: allows when that is less: a thinner arm is no floor anyone can use.
MIN_ARM = 0.9
#: Weight of the relative area error, against E_size's 1 per square metre of dimension
#: error. Linear, not squared: the floor the Ls' notches leave is cheapest in one large
#: room, as the plans have it, where a squared error spreads it over every room (56
#: planted briefs: linear 5, 10 and 20 against squared 30, bench/NOTES.md).
AREA_WEIGHT = 10.0
#: Price of each corner of a room beyond four (in m² of Eq. 6).
CORNER_WEIGHT = 0.05
#: Size errors and shortfalls are compared to this tolerance (m² and m).
TOL = 1e-6
#: Steps of a wall shorter than this (metres) are left as they are; a strip as deep as
#: a longer one may straighten it.
JOG = 1e-4
#: A strip thinner than this (metres) is not worth a corner.
MIN_STRIP = 0.05
#: The annealing's first temperature (m² of Eq. 6) and its last, as a share of it.
TEMPERATURE = 0.3
COOLED = 0.01
#: Steps the annealing tries per room, over all its restarts (about 0.1 ms each on
#: 2020s hardware, most strips refused unbuilt). On 24 layouts of 10-14 rooms as the
#: reshaping gets them, two seeds each, with no deadline: mean area error 0.111 with
#: 1,200, 0.099 with 2,400, 0.094 with 4,800 (1.4, 2.4 and 4.1 s); 2,400 fits the
#: reshaping's time on most floors (bench/NOTES.md).
TRIES_PER_ROOM = 2400
#: Independent runs from the same layout, the best kept: one run's end depends much on
#: its first moves (planted briefs: area error 0.04 to 0.17 over six seeds of one).
RESTARTS = 3
#: Steps tried between two looks at the clock and the stop flag.
STOP_EVERY = 64
#: Pseudo-rooms of uncovered floor are named so.
GAP = "~gap"
#: The share of the floor a result must cover: the checker's goal with the pipeline's
#: margin (solver.verify.checker.COVERAGE_GOAL + solver.pipeline.run.COVER_MARGIN, both
#: above this layer).
COVER_GOAL = 0.9905
#: Margin (in cost) by which a strip's cost floor must exceed what the annealing allows
#: before it is refused unbuilt: the floor ignores the snapping of shapes to the grid.
BOUND_SLACK = 1e-4
#: Share of the steps tried that swap two rooms' floors.
SWAP_SHARE = 0.2
#: Share of the steps tried that nest a room in a corner of another (`_nest`).
NEST_SHARE = 0.1


#: A rectangle as (x0, y0, x1, y1): the cheap arithmetic of refusing a strip unbuilt.
Rect = tuple[float, float, float, float]


@dataclass(frozen=True)
class RoomNeeds:
    """What the brief asks of one room, for checking a changed shape quickly."""

    room: Room
    corners: int
    arm: float
    edges: tuple[LineString, ...]


@dataclass(frozen=True)
class ReshapeResult:
    """The rooms after reshaping, the steps taken and the steps tried."""

    rooms: dict[str, list[Box]]
    steps: int
    candidates: int


def reshape(problem: Problem, domain: Domain, rooms: Mapping[str, Sequence[Box]], *,
            deadline: float, seed: int = 0,
            should_stop: Callable[[], bool] | None = None) -> ReshapeResult:
    """Lower Eq. 12 of a layout by moving strips of floor between neighbours (a gap
    counts as a neighbour that costs lambda_cover per m²), annealing until `deadline`
    (time.monotonic()), `RESTARTS` times from `rooms` with seeds drawn from `seed`, each
    with an equal share of the time left. Returns the best layout found that covers as
    much as the coverage goal asks and has no higher Eq. 12 than `rooms`; unchanged
    rooms as given."""
    best: tuple[float, ReshapeResult] | None = None
    steps = candidates = 0
    for k in range(RESTARTS):
        left = deadline - time.monotonic()
        if left <= 0 or (should_stop is not None and should_stop()):
            break
        total, result = _anneal(problem, domain, rooms,
                                deadline=time.monotonic() + left / (RESTARTS - k),
                                seed=seed * RESTARTS + k, should_stop=should_stop)
        steps += result.steps
        candidates += result.candidates
        if best is None or total < best[0] - TOL:
            best = (total, result)
    if best is None:
        return ReshapeResult({r: list(b) for r, b in rooms.items()}, 0, 0)
    return ReshapeResult(best[1].rooms, steps, candidates)


def _anneal(problem: Problem, domain: Domain, rooms: Mapping[str, Sequence[Box]], *,
            deadline: float, seed: int,
            should_stop: Callable[[], bool] | None) -> tuple[float, ReshapeResult]:
    """One annealing run of `reshape`: its best layout, with the total cost it lowers
    (Eq. 12's terms, the area error and the corners; infinite when nothing was found)."""
    shapes = {r: shape_of(boxes) for r, boxes in rooms.items() if boxes}
    unchanged = ReshapeResult({r: list(b) for r, b in rooms.items()}, 0, 0)
    if len(shapes) < 2 or any(s is None for s in shapes.values()):
        return math.inf, unchanged
    state: dict[str, Polygon] = {r: s for r, s in shapes.items() if s is not None}
    needs = {room.id: room_needs(problem, domain, room, state.get(room.id))
             for room in problem.rooms if room.id in state}
    adjacency = [(adj.a, adj.partners, adj.min_contact) for adj in problem.adjacency]
    by_room: dict[str, list[int]] = {}
    for k, (a, partners, _) in enumerate(adjacency):
        for r in (a, *partners):
            by_room.setdefault(r, []).append(k)
    cover = problem.weights.cover
    size_weight = problem.weights.size
    goal = COVER_GOAL * domain.area

    def costs(room: str, shape: BaseGeometry) -> _Cost:
        if room.startswith(GAP):
            return _Cost(cover * shape.area, cover * shape.area)
        c = _cost(needs.get(room), shape)
        return _Cost(size_weight * c.size, size_weight * c.total)

    def lowest(room: str, bounds: Rect | None, area: float) -> float:
        """The least `costs(room, shape).total` of a shape with these bounds and area."""
        if room.startswith(GAP):
            return cover * area
        return size_weight * _cost_floor(needs.get(room), bounds, area)

    state.update(_gaps(domain, state))
    cost = {r: costs(r, p) for r, p in state.items()}
    # Each room's floor as rectangles (x0, y0, x1, y1), kept until the room changes.
    pieces: dict[str, list[Rect]] = {}

    def within(changes: Mapping[str, tuple[Rect | None, float]], allowed: float) -> bool:
        """Whether rooms of these bounds and areas could raise the cost by less than
        `allowed`: if not, the step is refused before its shapes are built."""
        floor = sum(lowest(r, bounds, area) - cost[r].total
                    for r, (bounds, area) in changes.items())
        return floor <= 0 or floor < allowed + BOUND_SLACK

    def rectangles_in(room: str) -> list[Rect]:
        if room not in pieces:
            pieces[room] = [(p.x0, p.y0, p.x1, p.y1) for p in rectangles_of(state[room])]
        return pieces[room]
    start = sum(c.size for c in cost.values())
    best = (sum(c.total for c in cost.values()), dict(state))
    rng = random.Random(seed)
    steps = candidates = 0
    pairs, into_rooms = _neighbour_pairs(state)
    strips: dict[tuple[str, str], list[tuple[float, float, float, float]]] = {}
    movable = sorted(needs)
    # The schedule counts steps tried, not seconds: the same layout and seed give the
    # same result, unless the deadline cuts the schedule short.
    planned = TRIES_PER_ROOM * len(movable) // RESTARTS
    while pairs and candidates < planned:
        candidates += 1
        if candidates % STOP_EVERY == 0 and (time.monotonic() >= deadline or (
                should_stop is not None and should_stop())):
            break
        # Annealing: worse steps are taken at first, ever more rarely. A step is taken
        # when it raises the cost by less than `allowed` (Metropolis, drawn up front so
        # that a strip can be refused before its polygons are built).
        heat = TEMPERATURE * (COOLED ** (candidates / planned))
        drawn = rng.random()
        allowed = math.inf if drawn <= 0.0 else -heat * math.log(drawn)
        within_allowed = functools.partial(within, allowed=allowed)
        pick = rng.random()
        if pick < SWAP_SHARE:
            # Two rooms trade floors: the one step that moves a room across the plan.
            a, b = rng.sample(movable, 2)
            moved = {a: state[b], b: state[a]}
        elif pick < SWAP_SHARE + NEST_SHARE:
            nested = _nest(state, needs, pairs, rng, rectangles_in, within_allowed)
            if nested is None:
                continue
            moved = nested
        else:
            # Uncovered floor is the costliest: rooms grow into it half the time.
            a, b = rng.choice(into_rooms if into_rooms and rng.random() < 0.5 else pairs)
            if (a, b) not in strips:
                strips[a, b] = list(_strip_cuts(state[a], state[b], needs.get(a),
                                                needs.get(b)))
            if not strips[a, b]:
                continue
            cut = rng.choice(strips[a, b])
            taken = _strip_extent(rectangles_in(a), cut)
            if taken is None:
                continue
            # Most strips are refused: a floor under their cost from areas and bounding
            # boxes alone (the corners' price is left out) refuses them without shapely.
            area, strip_bounds, rest_bounds = taken
            if rest_bounds is None and not a.startswith(GAP):
                continue  # the strip would take the whole room
            if not within_allowed({
                    a: (rest_bounds, state[a].area - area),
                    b: (_hull(state[b].bounds, strip_bounds), state[b].area + area)}):
                continue
            strip = state[a].intersection(box(*cut))
            if strip.area <= JOG * JOG:
                continue
            new_a = _clean(state[a].difference(strip), a.startswith(GAP))
            new_b = _clean(state[b].union(strip), b.startswith(GAP))
            if new_a is None or new_b is None:
                continue
            moved = {a: new_a, b: new_b}
        new_cost = {r: costs(r, shape) for r, shape in moved.items()}
        delta = sum(c.total for c in new_cost.values()) - sum(cost[r].total for r in moved)
        if delta > 0 and delta >= allowed:
            continue
        if not all(r.startswith(GAP) or shape_ok(needs[r], new, state[r])
                   for r, new in moved.items()):
            continue
        trial = {**state, **moved}
        if not keeps_demands(adjacency, by_room, state, trial, tuple(moved)):
            continue
        state = trial
        cost.update(new_cost)
        steps += 1
        for r in moved:
            pieces.pop(r, None)
        touched = set(moved)
        if any(r.startswith(GAP) for r in moved):
            # Gaps merge and split: recount them.
            touched |= {r for r in state if r.startswith(GAP)}
            pieces = {r: p for r, p in pieces.items() if not r.startswith(GAP)}
            state = {r: p for r, p in state.items() if not r.startswith(GAP)}
            state.update(_gaps(domain, state))
            touched |= {r for r in state if r.startswith(GAP)}
            cost = {r: cost[r] if not r.startswith(GAP) else costs(r, p)
                    for r, p in state.items()}
        pairs, into_rooms = _neighbour_pairs(state, touched, pairs)
        # A pair's strips depend on its two rooms alone (gaps are renumbered).
        strips = {(a, b): cuts for (a, b), cuts in strips.items()
                  if a not in moved and b not in moved
                  and not a.startswith(GAP) and not b.startswith(GAP)}
        total = sum(c.total for c in cost.values())
        if (total < best[0] - TOL and sum(c.size for c in cost.values()) <= start + TOL
                and _covered(domain, state) >= goal):
            best = (total, dict(state))
    final = {r: p for r, p in best[1].items() if not r.startswith(GAP)}
    changed = {r for r in final if not final[r].equals(shapes[r])}
    out = {r: list(boxes) for r, boxes in rooms.items()}
    for r in changed:
        out[r] = rectangles_of(final[r])
    return best[0], ReshapeResult(out, steps, candidates)


def _nest(state: Mapping[str, Polygon], needs: Mapping[str, RoomNeeds],
          pairs: Sequence[tuple[str, str]], rng: random.Random,
          rectangles_in: Callable[[str], list[Rect]],
          within_allowed: Callable[[Mapping[str, tuple[Rect | None, float]]], bool],
          ) -> dict[str, Polygon] | None:
    """A room moves into a corner of another, at its target size, and a neighbour takes
    the floor it leaves: a bathroom set into the corner of a living room that thereby
    becomes an L, where strips alone would have to pass through worse layouts. The
    host may be that neighbour itself. None when the drawn move does not fit, or when
    `within_allowed` refuses the rooms' bounds and areas before their shapes are built
    (`rectangles_in`: a room's floor as rectangles)."""
    a, heir = rng.choice(pairs)
    if a.startswith(GAP) or heir.startswith(GAP):
        return None
    target = needs[a].room.target_size
    if target is None:
        return None
    hosts = [r for r in needs if r != a and state[r].area > target[0] * target[1]]
    if not hosts:
        return None
    host_id = rng.choice(hosts)
    inherited: BaseGeometry | None = None
    if host_id == heir:
        inherited = _clean(state[heir].union(state[a]))
        if inherited is None:
            return None
    host = inherited if inherited is not None else state[host_id]
    host_pieces = rectangles_in(host_id) + (rectangles_in(a) if host_id == heir else [])
    width, depth = target if rng.random() < 0.5 else target[::-1]
    x0, y0, x1, y1 = host.bounds
    # Where the host would keep a sliver thinner than an arm, the room takes it all.
    if x1 - x0 - width < MIN_ARM:
        width = x1 - x0
    if y1 - y0 - depth < MIN_ARM:
        depth = y1 - y0
    corners = list(dict.fromkeys(host.exterior.coords))
    vx, vy = rng.choice(corners)
    for sx, sy in rng.sample([(1, 1), (1, -1), (-1, 1), (-1, -1)], 4):
        corner = (min(vx, vx + sx * width), min(vy, vy + sy * depth),
                  max(vx, vx + sx * width), max(vy, vy + sy * depth))
        taken = _strip_extent(host_pieces, corner)
        if taken is not None and taken[0] >= width * depth - JOG * JOG:
            break  # the corner lies within the host
    else:
        return None
    _, _, kept = taken
    changes: dict[str, tuple[Rect | None, float]] = {
        a: (corner, width * depth), host_id: (kept, host.area - width * depth)}
    if host_id != heir:
        changes[heir] = (_hull(state[heir].bounds, state[a].bounds),
                         state[heir].area + state[a].area)
    if kept is None or not within_allowed(changes):
        return None
    rest = _clean(host.difference(box(*corner)))
    if rest is None:
        return None
    moved = {a: shapely.orient_polygons(box(*corner)), host_id: rest}
    if host_id != heir:
        inherited = _clean(state[heir].union(state[a]))
        if inherited is None:
            return None
        moved[heir] = inherited
    return moved


def _gaps(domain: Domain, state: Mapping[str, Polygon]) -> dict[str, Polygon]:
    """The uncovered parts of the floor as pseudo-rooms (`GAP` and a number)."""
    rest = shapely.set_precision(
        domain.free.difference(shapely.union_all(list(state.values()))), GRID)
    parts = [g for g in getattr(rest, "geoms", [rest])
             if isinstance(g, Polygon) and g.area > MIN_STRIP * MIN_STRIP]
    return {f"{GAP}{k}": g for k, g in enumerate(parts)}


def _covered(domain: Domain, state: Mapping[str, Polygon]) -> float:
    return domain.area - sum(p.area for r, p in state.items() if r.startswith(GAP))


@dataclass(frozen=True)
class _Cost:
    size: float  # the Eq. 12 term: E_size (Eq. 6) of the bounding box, or a gap's cover
    total: float  # plus the area and corner terms


def _cost(needs: RoomNeeds | None, shape: Polygon) -> _Cost:
    """E_size of the room's bounding box, and the total the annealing lowers: that,
    the relative area error (`AREA_WEIGHT`) and a small price per corner
    beyond a rectangle's (`CORNER_WEIGHT`): of two shapes equally near the targets,
    the simpler."""
    corners = CORNER_WEIGHT * (corner_count(shape) - 4)
    if needs is None or needs.room.target_size is None:
        return _Cost(0.0, corners)
    size, area = size_terms(needs.room.target_size, shape.bounds, shape.area)
    return _Cost(size, size + area + corners)


def _cost_floor(needs: RoomNeeds | None, bounds: Rect | None, area: float) -> float:
    """The least `_cost(needs, shape).total` of a shape with these bounds and area (its
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


def _strip_extent(pieces: Sequence[Rect], cut: Rect
                  ) -> tuple[float, Rect, Rect | None] | None:
    """What cutting the box `cut` out of a room made of the disjoint rectangles
    `pieces` takes: the strip's area and bounds, and the bounds of what the room keeps
    (None: nothing); None when the strip is no thicker than a jog."""
    cx0, cy0, cx1, cy1 = cut
    area = 0.0
    strip: list[Rect] = []
    rest: list[Rect] = []
    for x0, y0, x1, y1 in pieces:
        ix0, iy0, ix1, iy1 = max(x0, cx0), max(y0, cy0), min(x1, cx1), min(y1, cy1)
        if ix1 - ix0 <= 0 or iy1 - iy0 <= 0:
            rest.append((x0, y0, x1, y1))
            continue
        area += (ix1 - ix0) * (iy1 - iy0)
        strip.append((ix0, iy0, ix1, iy1))
        # What the piece keeps spans its whole width unless the cut spans its depth,
        # and then only the side(s) the cut leaves; the same across.
        across_x = cy0 <= y0 and cy1 >= y1
        across_y = cx0 <= x0 and cx1 >= x1
        if across_x and across_y:
            continue  # the cut takes the whole piece
        kx0, kx1 = x0, x1
        if across_x:
            kx0 = ix1 if cx0 <= x0 else x0
            kx1 = ix0 if cx1 >= x1 else x1
        ky0, ky1 = y0, y1
        if across_y:
            ky0 = iy1 if cy0 <= y0 else y0
            ky1 = iy0 if cy1 >= y1 else y1
        rest.append((kx0, ky0, kx1, ky1))
    if area <= JOG * JOG:
        return None
    kept = _hull(*rest) if rest else None
    return area, _hull(*strip), kept


def _hull(*boxes: Rect) -> Rect:
    """The bounding box of boxes (x0, y0, x1, y1)."""
    return (min(b[0] for b in boxes), min(b[1] for b in boxes),
            max(b[2] for b in boxes), max(b[3] for b in boxes))


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


def _clean(shape: BaseGeometry, gap: bool = False) -> BaseGeometry | None:
    """A step's result as one polygon without holes on the grid, or None; a gap may be
    anything (an emptied gap is gone)."""
    shape = shapely.set_precision(shape, GRID)
    if gap:
        return shape
    if (not isinstance(shape, Polygon) or shape.is_empty or shape.interiors
            or not shape.is_valid):
        return None
    return shapely.orient_polygons(shape.simplify(0))


def corner_count(shape: Polygon) -> int:
    return len(shape.exterior.coords) - 1


def _neighbour_pairs(state: Mapping[str, Polygon], changed: set[str] | None = None,
                     known: Sequence[tuple[str, str]] = ()
                     ) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """Ordered pairs of rooms sharing a wall (a gives, b takes), sorted, and those of
    them in which a gap gives. With `changed`, the `known` pairs of the other rooms
    stand and only the changed rooms' walls are measured again."""
    ids = sorted(state)
    tree = shapely.STRtree([state[r] for r in ids])
    asked = ids if changed is None else [r for r in ids if r in changed]
    found = set() if changed is None else {
        (a, b) for a, b in known if a not in changed and b not in changed}
    for k, j in zip(*tree.query([state[r] for r in asked], "touches"), strict=True):
        a, b = asked[k], ids[j]
        if a != b and shared_wall_length(state[a], state[b]) > MIN_STRIP:
            found |= {(a, b), (b, a)}
    pairs = sorted(found)
    return pairs, [ab for ab in pairs if ab[0].startswith(GAP)]


def _strip_cuts(a: Polygon, b: Polygon, needs_a: RoomNeeds | None,
                needs_b: RoomNeeds | None) -> Iterator[tuple[float, float, float, float]]:
    """Boxes (x0, y0, x1, y1) cutting strips of `a` along the walls it shares with `b`:
    across each straight stretch of the shared wall, or part of it, as deep as one of
    `a`'s own corners, or as makes the width (or depth) of `a` or `b` its target's. The
    strip is `a` within the box; only the one drawn is cut (most are never drawn)."""
    shared = a.boundary.intersection(b.boundary)
    for x0, y0, x1, y1 in _segments(shared):
        vertical = abs(x0 - x1) <= TOL
        c = x0 if vertical else y0
        lo, hi = (min(y0, y1), max(y0, y1)) if vertical else (min(x0, x1), max(x0, x1))
        if hi - lo <= MIN_STRIP:
            continue
        mid = (lo + hi) / 2
        probe = Point(c - 1e-3, mid) if vertical else Point(mid, c - 1e-3)
        sign = -1.0 if a.contains(probe) else 1.0  # which way a lies from the wall
        axis = 0 if vertical else 1
        a_lo, a_hi = _extent(a, axis)
        b_lo, b_hi = _extent(b, axis)
        depths = {abs(c - v) for v in _coords(a, axis)}
        ta, tb = _target(needs_a, axis), _target(needs_b, axis)
        if ta is not None:
            depths.add((a_hi - a_lo) - ta)  # a shrinks to its target across the wall
        if tb is not None:
            depths.add(tb - (b_hi - b_lo))  # b grows to its target across the wall
        depths = {t for t in depths if JOG <= t <= (a_hi - a_lo) + TOL}
        # Along the wall: the corners of either room, and where what a keeps (or b
        # takes) is as long as a target asks.
        along = [*_coords(a, 1 - axis), *_coords(b, 1 - axis)]
        for t in (_target(needs_a, 1 - axis), _target(needs_b, 1 - axis)):
            if t is not None:
                along += [lo + t, hi - t]
        cuts = {lo, hi} | {v for v in along if lo + MIN_STRIP < v < hi - MIN_STRIP}
        ends = sorted(cuts)
        spans = [(s, e) for i, s in enumerate(ends) for e in ends[i + 1:]]
        for t in sorted(depths):
            for s, e in spans:
                near, far = c, c + sign * t
                if vertical:
                    yield min(near, far), s, max(near, far), e
                else:
                    yield s, min(near, far), e, max(near, far)


def _segments(shared: BaseGeometry) -> Iterator[tuple[float, float, float, float]]:
    """The axis-aligned straight stretches of a shared wall, as (x0, y0, x1, y1)."""
    for stretch in straight_stretches(shared):
        (x0, y0), (x1, y1) = stretch.coords[0], stretch.coords[-1]
        if abs(x0 - x1) <= TOL or abs(y0 - y1) <= TOL:
            yield x0, y0, x1, y1


def _extent(shape: Polygon, axis: int) -> tuple[float, float]:
    x0, y0, x1, y1 = shape.bounds
    return (x0, x1) if axis == 0 else (y0, y1)


def _coords(shape: Polygon, axis: int) -> set[float]:
    return {p[axis] for p in shape.exterior.coords}


def _target(needs: RoomNeeds | None, axis: int) -> float | None:
    target = None if needs is None else needs.room.target_size
    return None if target is None else target[axis]


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
