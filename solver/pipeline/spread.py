"""A batch's layout moved apart from the plans the batch holds (docs/method.md,
"Different plans per seed (batches)").

Seeds of one brief often end in nearly the same plan: the brief's bounds leave a few
arrangements, and in each the walls settle where the size bounds and coverage push them,
so the nearest other plan of a batch differs on a median 4.5 % of the floor where 5 %
makes another plan (solver/distinct.py; bench/NOTES.md, "Repeated plans moved apart").
Solving again under another draw costs a whole solve and often lands in the same
cluster. Moving walls is cheap and keeps the arrangement: `spread_apart` moves whole
wall lines (every rectangle edge on one x or one y), one line at a time, each to where
the plan differs most from its nearest held plan, while the layout stays valid and
covers as much.

A whole line moved between its neighbouring lines keeps the rectangles' order, so rooms
that did not overlap still do not and the floor covered stays covered; what can break is
a room's size, ratio, contact or position, which a bounding-box precheck and then the
checker decide. The outline's and fixed rooms' lines stay.
"""

from __future__ import annotations

import random
import time
from collections.abc import Iterator, Mapping, Sequence

import numpy as np

from floorplan.models import Layout, Problem
from floorplan.solver.distinct import CELL, SAME_PLAN_SHARE, floor_grid
from floorplan.solver.geometry import Box, domain_lines, make_domain
from floorplan.solver.heuristics.reshape import reshape
from floorplan.solver.heuristics.variety import diverse_problem
from floorplan.solver.openings import connection_demands
from floorplan.solver.pipeline.assemble import with_rooms
from floorplan.solver.soft import room_soft
from floorplan.solver.verify.checker import CheckResult, check_layout

#: Seconds a layout's spreading takes at most (it ends sooner when it succeeds, 30 ms
#: on a 5-room flat, or finds no move; bench/NOTES.md, "Repeated plans moved apart").
SPREAD_SECONDS = 0.3
#: A wall line moves in steps of this many metres (the grid plans are compared on).
STEP = CELL
#: A line moved leaves at least this much (metres) to its neighbouring lines, or what it
#: left before when that was less: no rectangle thinner than a wall is made.
MIN_GAP = 0.6
#: The checker is run on at most this many of a round's candidates, best first.
CHECKS_PER_ROUND = 8
#: Lines are moved until the nearest held plan differs on this share of the floor: a
#: little beyond `SAME_PLAN_SHARE`, so the next plans do not land on its edge.
SPREAD_SHARE = 1.2 * SAME_PLAN_SHARE
#: Wall lines less than this apart (metres) move together: the strip between them is a
#: gap or a jog the search left, which a move should neither widen nor close.
BAND = 0.25
#: Seconds the reshaping toward other sizes may take when wall lines alone do not move
#: a plan apart (`_toward_other_sizes`), and the step its draw's seed takes from the
#: layout's.
RESHAPE_SECONDS = 0.1
SPREAD_SEED_STEP = 15_485_863
#: Coordinates this close (metres) are one wall line.
SAME_LINE = 1e-6

Rooms = dict[str, list[Box]]


def spread_layout(problem: Problem, layout: Layout, others: np.ndarray, *, seed: int,
                  seconds: float = SPREAD_SECONDS) -> Layout | None:
    """`layout` (a valid single-floor answer of `problem`) with wall lines moved until it
    differs from every plan of `others` (`solver.distinct` grids of the same floor, one
    row a plan) by more than `SAME_PLAN_SHARE`, in at most `seconds`; None when it
    cannot be moved so far, or for a layout of several floors or of regions."""
    if layout.floors is not None or problem.by_regions or not layout.report.valid:
        return None  # several floors, or regions and aisles: whole lines cross them
    rooms = {r.id: [Box.of(b) for b in r.rectangles] for r in layout.rooms}
    check = check_layout(problem, rooms)
    if not check.valid:
        return None
    until = time.monotonic() + seconds
    rng = random.Random(seed)
    moved = spread_apart(problem, rooms, check, others, until=until, rng=rng)
    if moved is None and (reshaped := _toward_other_sizes(problem, rooms, check, seed,
                                                          until)) is not None:
        moved = spread_apart(problem, *reshaped, others, until=until, rng=rng)
    return None if moved is None else with_rooms(problem, layout, *moved)


def _toward_other_sizes(problem: Problem, rooms: Rooms, check: CheckResult, seed: int,
                        until: float) -> tuple[Rooms, CheckResult] | None:
    """`rooms` reshaped toward sizes drawn anew within the brief's bounds (as a diverse
    solve draws them, under another seed): strips of floor traded between neighbours,
    rooms becoming Ls, for `RESHAPE_SECONDS`; kept when valid and covering as much.
    What wall lines alone cannot move apart, a new arrangement of floor often can."""
    drawn = connection_demands(diverse_problem(problem, (seed + SPREAD_SEED_STEP) % 2**31))
    result = reshape(drawn, make_domain(drawn), rooms,
                     deadline=min(until, time.monotonic() + RESHAPE_SECONDS), seed=seed)
    if result.steps == 0:
        return None
    again = check_layout(problem, result.rooms)
    if not again.valid or again.coverage < check.coverage - 1e-9:
        return None
    return result.rooms, again


def spread_apart(problem: Problem, rooms: Rooms, check: CheckResult, others: np.ndarray, *,
                 until: float, rng: random.Random) -> tuple[Rooms, CheckResult] | None:
    """`rooms` with whole wall lines moved, greedily, each time to the candidate whose
    plan lies farthest from its nearest plan among `others`, kept valid and covering as
    much as `check` says (the checker's verdict on `rooms`); the moved rooms and their
    check once the nearest plan differs by more than `SAME_PLAN_SHARE`, else None."""
    number = {room_id: k + 1 for k, room_id in enumerate(sorted(rooms))}

    def grid(state: Rooms) -> np.ndarray:
        return floor_grid([(number[i], b.x0, b.y0, b.x1, b.y1)
                           for i, rects in state.items() for b in rects])

    base = grid(rooms)
    if others.shape[0] == 0:
        return rooms, check
    if others.shape[1] != base.size:
        return None

    def nearest(g: np.ndarray) -> int:
        return int((others != g).sum(axis=1).min())

    fixed = _fixed_lines(problem)
    current, current_check, distance = rooms, check, nearest(base)
    # A move keeps the rectangles apart, so what they cover is the sum of their areas:
    # a line bordering bare floor that moves into it is dropped before the checker.
    floor = _area(rooms) - 1e-9
    while distance <= SPREAD_SHARE * base.size and time.monotonic() < until:
        candidates = []
        for moved in _line_moves(current, fixed):
            if time.monotonic() >= until:  # a large floor has thousands of moves
                break
            if _area(moved) < floor or not _fits_bounds(problem, moved):
                continue
            g = grid(moved)
            if g.size == base.size and (d := nearest(g)) > distance:
                candidates.append((d, rng.random(), moved))
        candidates.sort(key=lambda c: (c[0], c[1]), reverse=True)
        for d, _, moved in candidates[:CHECKS_PER_ROUND]:
            again = check_layout(problem, moved)
            if again.valid and again.coverage >= check.coverage - 1e-9:
                current, current_check, distance = moved, again, d
                break
        else:
            break
    if distance <= SAME_PLAN_SHARE * base.size:
        return None
    return current, current_check


def _area(rooms: Rooms) -> float:
    return sum(b.area for rects in rooms.values() for b in rects)


def _fixed_lines(problem: Problem) -> tuple[list[float], list[float]]:
    """The x and y lines no move may take: the outline's, the obstacles' and the fixed
    rooms' walls."""
    xs, ys = domain_lines(problem)
    for room in problem.rooms:
        xs += [x for x, _ in room.fixed or []]
        ys += [y for _, y in room.fixed or []]
    return xs, ys


def _line_moves(rooms: Rooms, fixed: tuple[list[float], list[float]]) -> Iterator[Rooms]:
    """Every layout with one band of wall lines of `rooms` (lines less than `BAND`
    apart, as a strip the search left between two rooms: moved together, the strip
    neither grows nor closes) moved by a multiple of `STEP` between its neighbouring
    lines, keeping `MIN_GAP` to them (or the gap it had when smaller)."""
    for axis in (0, 1):
        ends = [(b.x0, b.x1) if axis == 0 else (b.y0, b.y1)
                for rects in rooms.values() for b in rects]
        bands = _bands(v for pair in ends for v in pair)
        for i in range(1, len(bands) - 1):
            band = bands[i]
            if any(band[0] - SAME_LINE <= f <= band[-1] + SAME_LINE for f in fixed[axis]):
                continue
            below, above = bands[i - 1][-1], bands[i + 1][0]
            lo = below + min(MIN_GAP, band[0] - below) - band[0]
            hi = above - min(MIN_GAP, above - band[-1]) - band[-1]
            for k in range(int(lo / STEP), int(hi / STEP) + 1):
                if k != 0 and lo - SAME_LINE <= k * STEP <= hi + SAME_LINE:
                    yield _band_moved(rooms, axis, band, k * STEP)


def _bands(values: Iterator[float]) -> list[list[float]]:
    """`values` as sorted bands of distinct lines, each line less than `BAND` from the
    previous one of its band."""
    bands: list[list[float]] = []
    for v in sorted(values):
        if bands and v - bands[-1][-1] <= SAME_LINE:
            continue
        if bands and v - bands[-1][-1] < BAND:
            bands[-1].append(v)
        else:
            bands.append([v])
    return bands


def _band_moved(rooms: Rooms, axis: int, band: list[float], by: float) -> Rooms:
    def at(c: float) -> float:
        return c + by if band[0] - SAME_LINE <= c <= band[-1] + SAME_LINE else c

    if axis == 0:
        return {i: [Box(at(b.x0), b.y0, at(b.x1), b.y1) for b in rects]
                for i, rects in rooms.items()}
    return {i: [Box(b.x0, at(b.y0), b.x1, at(b.y1)) for b in rects]
            for i, rects in rooms.items()}


def _fits_bounds(problem: Problem, rooms: Mapping[str, Sequence[Box]]) -> bool:
    """Whether every room's bounding box keeps its hard size and ratio bounds and its
    rectangles its hard positions: the checker's C_size (Eq. 5), C_ratio (Eq. 7) and
    C_position (Eq. 8) verdicts, cheaply, to spare it the candidates that break them."""
    for room in problem.rooms:
        rects = rooms.get(room.id)
        if not rects:
            continue
        soft = room_soft(problem, room)
        size = (max(b.x1 for b in rects) - min(b.x0 for b in rects),
                max(b.y1 for b in rects) - min(b.y0 for b in rects))
        if room.min_size is not None and "min_size" not in soft and any(
                size[k] < room.min_size[k] - 1e-6 for k in (0, 1)):
            return False
        if room.max_size is not None and "max_size" not in soft and any(
                size[k] > room.max_size[k] + 1e-6 for k in (0, 1)):
            return False
        if room.aspect_ratio is not None and "aspect_ratio" not in soft:
            lo, hi = room.aspect_ratio
            if not lo * min(size) - 1e-6 <= max(size) <= hi * min(size) + 1e-6:
                return False
        if "positions" not in soft and not all(
                any(b.contains_point(x, y) for b in rects) for x, y in room.positions):
            return False
    return True
