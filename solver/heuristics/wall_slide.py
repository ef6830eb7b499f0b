"""Sliding whole walls of a covering layout: the moves the reshaping cannot chain
(docs/method.md, "The steps", step 6).

The reshaping (reshape/) moves one strip between two rooms at a time. A wall that
several rooms share (a corridor's side with three bedrooms along it) or a room that
should slide between its neighbours (both its walls moved the same way) needs two or
more such strips in a row, each worse than the layout on its own, so the annealing
rarely finds them. Here a *wall* is every rectangle edge on one line whose rooms touch
across it; when the rooms on its two sides cover the same stretch of it, moving it
takes floor from the rectangles on one side and gives it to those on the other, so
no room overlaps another and the floor covered stays covered, as long as no rectangle
gets thinner than its room's arm. One wall, or two walls of one rectangle together (the
rectangle slides, or grows on both sides), moves by the distance that puts a room's
area or bounding box at its target, the one that lowers the reshaping's cost most
(E_size, Eq. 6, the relative area error and the corners) and keeps every room's own
constraints and contacts; repeated until no move lowers it (coordinate descent).

Uncovered floor takes part as rectangles that cost lambda_cover per m² (Eq. 12), or
`SHORT_PRICE` while the layout covers less than the coverage goal, and may only
shrink: a room at its largest beside a gap slides across it while the room behind
grows into the floor it leaves, which no single strip can do.

Plain arithmetic on rectangles, shapely only for a move's checks: tens of milliseconds
on a dozen rooms.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import Polygon

from floorplan.models import Problem
from floorplan.solver.geometry import Box, Domain, bounding_box, rectangles_of
from floorplan.solver.heuristics.reshape.anneal import COVER_GOAL
from floorplan.solver.heuristics.reshape.needs import (
    CORNER_WEIGHT,
    MIN_ARM,
    RoomNeeds,
    corner_count,
    keeps_demands,
    room_needs,
    shape_of,
    shape_ok,
    size_terms,
)
from floorplan.solver.heuristics.reshape.strips import GAP

#: Coordinates this close (metres) are one line; overlaps shorter are touches.
SAME = 1e-6
#: Moves shorter than this (metres) are not worth a wall; moves are rounded to a
#: millimetre, as the output is.
SHORTEST = 0.005
DIGITS = 3
#: A move must lower the cost by more than this (m² of Eq. 6).
GAIN = 1e-4
#: The candidates of one move checked with shapely, cheapest first.
CHECKED = 4
#: The price of a m² of uncovered floor (as m² of Eq. 6) while the layout covers less
#: than the coverage goal: covering comes first (a layout short of it is no answer),
#: though lambda_cover is often 1 where the rooms' relative area errors weigh 10.
SHORT_PRICE = 50.0
#: Uncovered floor thinner than this (metres) is left out: SCIP's rounding, not a gap.
SLIVER = 1e-3

#: A rectangle of a room: the room's id and the rectangle's index in its list.
Member = tuple[str, int]


@dataclass(frozen=True)
class Wall:
    """The rectangle edges on one line (`axis` 0: x = `at`, a vertical wall; 1: y = `at`)
    whose rectangles touch across it: `below` ends on it (its x1 or y1), `above`
    starts on it, and both sides cover the same stretch."""

    axis: int
    at: float
    below: tuple[Member, ...]
    above: tuple[Member, ...]


#: A move: walls and the direction each moves in, all by the same distance.
Move = tuple[tuple[Wall, int], ...]


def slide_walls(problem: Problem, domain: Domain, rooms: Mapping[str, Sequence[Box]], *,
                deadline: float, should_stop: Callable[[], bool] | None = None
                ) -> tuple[dict[str, list[Box]], int]:
    """`rooms` (a layout without overlaps) with walls slid while a move lowers the
    reshaping's cost and keeps every room's constraints and contacts no worse, until
    `deadline` (time.monotonic()); and the number of moves made."""
    state = {r: list(boxes) for r, boxes in rooms.items()}
    shapes = {r: shape_of(boxes) for r, boxes in state.items() if boxes}
    if any(s is None for s in shapes.values()):
        return state, 0  # a room of rectangles that are not one polygon: leave it
    polygons: dict[str, Polygon] = {r: s for r, s in shapes.items() if s is not None}
    needs = {room.id: room_needs(problem, domain, room, polygons.get(room.id))
             for room in problem.rooms if room.id in polygons}
    gaps = _gaps(domain, polygons.values())
    state.update(gaps)
    uncovered = sum(b.area for boxes in gaps.values() for b in boxes)
    cover = problem.weights.cover
    if uncovered > (1 - COVER_GOAL) * domain.area:
        cover = max(cover, SHORT_PRICE)
    adjacency = [(adj.a, adj.partners, adj.min_contact) for adj in problem.adjacency]
    by_room: dict[str, list[int]] = {}
    for k, (a, partners, _) in enumerate(adjacency):
        for r in (a, *partners):
            by_room.setdefault(r, []).append(k)
    price = _Price(needs, cover)
    moves = 0
    tried: set[Move] = set()  # moves that found nothing to gain
    while True:
        made = False
        # Moves that close a gap first: when the layout is short of coverage they gain
        # the most, and the time may not last for every move.
        for move in sorted(_moves(_walls(state)),
                           key=lambda m: not any(r.startswith(GAP) for r in _rooms(m))):
            if move in tried:
                continue
            if time.monotonic() >= deadline or (should_stop is not None and should_stop()):
                return _rooms_only(state), moves
            for gain, changed in _best_first(state, price, move):
                new = {r: shape_of(boxes) for r, boxes in changed.items()
                       if not r.startswith(GAP)}
                if (gain + _corner_change(polygons, new) >= -GAIN
                        or not _acceptable(needs, polygons, new, adjacency, by_room)):
                    continue
                # Moves of other rooms gain what they gained before.
                tried = {m for m in tried if not _rooms(m) & changed.keys()}
                state.update(changed)
                for r in changed:
                    if r.startswith(GAP):  # a gap slid shut leaves a rectangle of no area
                        state[r] = [b for b in state[r] if b.width > SAME and b.depth > SAME]
                polygons.update({r: p for r, p in new.items() if p is not None})
                moves += 1
                made = True
                break
            if made:
                break  # the walls changed: list them again
            tried.add(move)
        if not made:
            return _rooms_only(state), moves


@dataclass(frozen=True)
class _Price:
    """The reshaping's cost of a room but its corners (E_size of its bounding box and
    its weighted relative area error), and a gap's per m²."""

    needs: Mapping[str, RoomNeeds]
    cover: float

    def __call__(self, room: str, boxes: Sequence[Box]) -> float:
        if room.startswith(GAP):
            return self.cover * sum(b.area for b in boxes)
        needs = self.needs.get(room)
        if needs is None or needs.room.target_size is None or not boxes:
            return 0.0
        hull = bounding_box(boxes)
        return sum(size_terms(needs.room.target_size, (hull.x0, hull.y0, hull.x1, hull.y1),
                              sum(b.area for b in boxes)))


def _gaps(domain: Domain, shapes: Iterable[Polygon]) -> dict[str, list[Box]]:
    """The uncovered floor as rectangles, each a pseudo-room of its own."""
    rest = domain.free.difference(shapely.union_all(list(shapes)))
    boxes = [b for part in getattr(rest, "geoms", [rest]) if part.area > SLIVER * SLIVER
             for b in rectangles_of(part)]
    return {f"{GAP}{k}": [b] for k, b in enumerate(boxes)
            if b.width > SLIVER and b.depth > SLIVER}


def _rooms(move: Move) -> set[str]:
    return {r for wall, _ in move for r, _ in (*wall.below, *wall.above)}


def _rooms_only(state: Mapping[str, list[Box]]) -> dict[str, list[Box]]:
    return {r: boxes for r, boxes in state.items() if not r.startswith(GAP)}


def _walls(rooms: Mapping[str, Sequence[Box]]) -> list[Wall]:
    """Every wall of the layout that can move: its rectangles on both sides cover the
    same stretch of the line (none meets the outline, an obstacle or a gap)."""
    walls: list[Wall] = []
    for axis in (0, 1):
        lines: dict[float, list[tuple[bool, Member, float, float]]] = {}
        for r, boxes in rooms.items():
            for i, b in enumerate(boxes):
                low, high = (b.x0, b.x1) if axis == 0 else (b.y0, b.y1)
                span = (b.y0, b.y1) if axis == 0 else (b.x0, b.x1)
                lines.setdefault(round(high, 6), []).append((True, (r, i), *span))
                lines.setdefault(round(low, 6), []).append((False, (r, i), *span))
        for at, edges in lines.items():
            walls += [Wall(axis, at, *sides) for sides in _touching(edges)]
    return walls


def _touching(edges: Sequence[tuple[bool, Member, float, float]]
              ) -> Iterator[tuple[tuple[Member, ...], tuple[Member, ...]]]:
    """The edges of one line grouped by touching across it (an edge ending on the line
    overlaps one starting on it), each group as (ending, starting) when both sides
    cover the same stretch."""
    group = list(range(len(edges)))

    def root(k: int) -> int:
        while group[k] != k:
            group[k] = group[group[k]]
            k = group[k]
        return k
    for a, (ends_a, _, lo_a, hi_a) in enumerate(edges):
        for b, (ends_b, _, lo_b, hi_b) in enumerate(edges):
            if ends_a and not ends_b and min(hi_a, hi_b) - max(lo_a, lo_b) > SAME:
                group[root(a)] = root(b)
    members: dict[int, list[int]] = {}
    for k in range(len(edges)):
        members.setdefault(root(k), []).append(k)
    for ks in members.values():
        below = [edges[k] for k in ks if edges[k][0]]
        above = [edges[k] for k in ks if not edges[k][0]]
        if below and above and _stretch(below) == _stretch(above):
            yield tuple(e[1] for e in below), tuple(e[1] for e in above)


def _stretch(edges: Sequence[tuple[bool, Member, float, float]]) -> list[tuple[float, float]]:
    """The union of the edges' spans, as sorted intervals rounded to `SAME`."""
    merged: list[list[float]] = []
    for _, _, lo, hi in sorted(edges, key=lambda e: e[2]):
        if merged and lo <= merged[-1][1] + SAME:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return [(round(lo, 6), round(hi, 6)) for lo, hi in merged]


def _moves(walls: Sequence[Wall]) -> Iterator[Move]:
    """Each wall alone, then each pair of parallel walls of one rectangle moved the
    same way (the rectangle slides) and opposite ways (it grows or shrinks)."""
    for wall in walls:
        yield ((wall, 1),)
    starting: dict[tuple[int, Member], list[Wall]] = {}
    for wall in walls:
        for m in wall.above:
            starting.setdefault((wall.axis, m), []).append(wall)
    for wall in walls:
        for m in wall.below:
            for start in starting.get((wall.axis, m), ()):
                yield ((start, 1), (wall, 1))
                yield ((start, 1), (wall, -1))


def _best_first(rooms: Mapping[str, list[Box]], price: _Price, move: Move
                ) -> list[tuple[float, dict[str, list[Box]]]]:
    """The change of cost (corners left out) and the changed rooms of up to `CHECKED`
    distances for `move` that lower the cost, lowest first: the distances that put a
    moved room's area, width or depth at its target, its width or depth at a bound of
    its size (a millimetre inside), and the move's limits. No gap grows."""
    needs = price.needs
    # Per unit of distance: how much wider each moved rectangle gets.
    widen: dict[Member, int] = {}
    for wall, sign in move:
        for m in wall.below:
            widen[m] = widen.get(m, 0) + sign
        for m in wall.above:
            widen[m] = widen.get(m, 0) - sign
    axis = move[0][0].axis
    lowest, highest = -math.inf, math.inf
    slope: dict[str, float] = {}  # m² a room gains per metre moved
    for (r, i), k in widen.items():
        b = rooms[r][i]
        width, length = (b.width, b.depth) if axis == 0 else (b.depth, b.width)
        slope[r] = slope.get(r, 0.0) + k * length
        if k == 0:
            continue
        # No rectangle gets thinner than its room's arm (or than it is); a gap's may
        # close.
        arm = 0.0 if r.startswith(GAP) else needs[r].arm if r in needs else MIN_ARM
        room = (width - min(width, arm)) / abs(k)
        if k > 0:
            lowest = max(lowest, -room)
        else:
            highest = min(highest, room)
    if highest - lowest < 2 * SHORTEST:
        return []
    distances = {lowest, highest}
    for r in slope:
        room = needs[r].room if r in needs else None
        if room is None or room.target_size is None:
            continue
        target = room.target_size
        if abs(slope[r]) > SAME:
            distances.add((target[0] * target[1] - sum(b.area for b in rooms[r])) / slope[r])
        hull = bounding_box(rooms[r])
        lo, hi = (hull.x0, hull.x1) if axis == 0 else (hull.y0, hull.y1)
        # The bounding box's width (or depth) at its target, or a millimetre inside a
        # bound of its size (the distance is rounded to one).
        sizes = [target[axis]]
        if room.min_size:
            sizes.append(room.min_size[axis] + 10 ** -DIGITS)
        if room.max_size:
            sizes.append(room.max_size[axis] - 10 ** -DIGITS)
        for wall, sign in move:
            for size in sizes:
                distances |= {sign * (lo + size - wall.at), sign * (hi - size - wall.at)}
    opening = sum(k for r, k in slope.items() if r.startswith(GAP))  # m² of gap per metre
    before = sum(price(r, rooms[r]) for r in slope)
    scored: list[tuple[float, dict[str, list[Box]]]] = []
    for d in {round(min(max(d, lowest), highest), DIGITS) for d in distances}:
        if (abs(d) < SHORTEST or not lowest - SAME <= d <= highest + SAME
                or d * opening > SAME):
            continue
        changed = _moved(rooms, move, d)
        after = sum(price(r, changed[r]) for r in slope)
        if after < before - GAIN:
            scored.append((after - before, changed))
    scored.sort(key=lambda s: s[0])
    # The corners' price is left to the check: shapes are built only for these.
    return scored[:CHECKED]


def _moved(rooms: Mapping[str, list[Box]], move: Move, d: float) -> dict[str, list[Box]]:
    """The rooms `move` by distance `d` changes, with their rectangles moved."""
    changed: dict[str, list[Box]] = {}
    for wall, sign in move:
        step = sign * d
        for side, members in ((0, wall.below), (1, wall.above)):
            for r, i in members:
                boxes = changed.setdefault(r, list(rooms[r]))
                b = boxes[i]
                if wall.axis == 0:
                    boxes[i] = (Box(b.x0, b.y0, b.x1 + step, b.y1) if side == 0
                                else Box(b.x0 + step, b.y0, b.x1, b.y1))
                else:
                    boxes[i] = (Box(b.x0, b.y0, b.x1, b.y1 + step) if side == 0
                                else Box(b.x0, b.y0 + step, b.x1, b.y1))
    return changed


def _corner_change(polygons: Mapping[str, Polygon], new: Mapping[str, Polygon | None]
                   ) -> float:
    """The corners' price of the changed rooms, after less before."""
    if any(p is None for p in new.values()):
        return math.inf
    return CORNER_WEIGHT * sum(corner_count(p) - corner_count(polygons[r])
                               for r, p in new.items() if p is not None)


def _acceptable(needs: Mapping[str, RoomNeeds], polygons: Mapping[str, Polygon],
                new: Mapping[str, Polygon | None],
                adjacency: Sequence[tuple[str, Sequence[str], float]],
                by_room: Mapping[str, list[int]]) -> bool:
    """Every changed room is one polygon that keeps its own constraints and its
    contacts no worse than before (the reshaping's rules)."""
    if any(p is None for p in new.values()):
        return False
    shapes = {r: p for r, p in new.items() if p is not None}
    if not all(shape_ok(needs[r], p, polygons[r]) for r, p in shapes.items() if r in needs):
        return False
    return keeps_demands(adjacency, by_room, polygons, {**polygons, **shapes}, tuple(shapes))

