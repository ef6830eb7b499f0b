"""A first layout by slicing, for problems whose rooms ask only for sizes and guide
points: a constructive start, complete and covering at once (docs/method.md, "Size-only
problems: slicing").

The free floor is cut into rectangles (`rectangles_of`), each rectangle into rows,
and the rooms are dealt to the rows by target area, a room with a guide point into
the row that holds it. With that order fixed, the rooms of a row side by side fill it
exactly and the rows stacked fill their rectangle, so inside (Eq. 1), non-overlap
(Eq. 2) and full coverage hold by construction, and what is left is a small convex QP:
the row heights and room widths that minimise E_size (Eq. 6) under C_size (Eq. 5),
C_ratio (Eq. 7, each room keeping the orientation of its target) and C_pos (Eq. 8),
all linear once the order is known. A layout of 150 rooms comes out complete and
fully covering in well under a second, where the MIQP needs many seconds for a first,
partly covering one.
"""

from __future__ import annotations

import math
import random
import statistics
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import shapely

from floorplan.models import Problem, Room
from floorplan.solver.geometry import Box, Domain, largest_box_around, rectangles_of
from floorplan.solver.heuristics.row_search import (
    Demands,
    RowPlan,
    anneal_rows,
    energy,
    kicked,
    sizeable,
)
from floorplan.solver.heuristics.row_sizes import aimed_size, size_bounds, size_rows

#: Row counts tried per region, relative to the region's depth over the typical
#: target depth; the plan with the least E_size wins.
ROW_TRIES = (0, -1, 1)

#: Passes of the dealing's hill-climb; each tries every loose room in every other row.
BALANCE_PASSES = 4

#: Rooms up to which adjacency and boundary demands are sliced too ...
DEMANDS_UP_TO = 40
#: ... and up to which a door tree is: every room but a few tied to another
#: (adjacencies at least `DOOR_TREE_SHARE` of the rooms). Rows seldom hold a tree of
#: doors on ten rooms or more: of 57 planted briefs of 10-14 rooms, rows were found
#: for 2 (both also tiled), and the bench's 13- and 15-room cases get none; each failure
#: cost 0.35-0.7 s of level 1. Without it their first valid layouts come 0.5-1.1 s
#: sooner, Eq. 12 unchanged (bench/NOTES.md, "A slower machine, a stall stop for
#: batches, window schedules, and where 14 rooms' time goes").
DOOR_TREE_UP_TO = 9
DOOR_TREE_SHARE = 0.5

#: Row plans (each with every demand able to hold) sized by the QP; the best is kept.
PLANS_WANTED = 1

#: Annealing moves per room without a better plan before a plan is sized.
ANNEAL_PATIENCE = 20

#: One random move per this many rooms shakes a plan before the next annealing.
KICK_SHARE = 4

#: An empty row smaller than this (m²) costs nothing: it is dropped and its region's
#: other rows take its depth.
MIN_ROW_AREA = 1e-9


#: With `options.diverse` (a batch's worker lays out one brief many times):
#: after row slicing found nothing this many times in this process for a brief's
#: structure, and never anything, it is not tried again for that structure.
SKIP_AFTER_FAILURES = 2

#: Per process: structure of a brief (`structure_key`) -> times slicing found nothing
#: for it, or -1 once it found something.
_SLICING_FAILURES: dict[str, int] = {}


def structure_key(problem: Problem) -> str:
    """What decides whether rows can hold a brief, whatever sizes it aims at: the
    outline, obstacles, the rooms' bounds and demands, the adjacencies (targets, seed
    and time limit left out)."""
    rooms = [room.model_dump(mode="json", exclude={"target_size"}) for room in problem.rooms]
    return problem.model_copy(update={"rooms": []}).model_dump_json(
        exclude={"options", "name"}) + repr(rooms)


def slicing_known_to_fail(problem: Problem) -> bool:
    """Whether a diverse solve should skip slicing: it found nothing for this brief's
    structure `SKIP_AFTER_FAILURES` times in this process, and never anything."""
    if not problem.options.diverse:
        return False
    return _SLICING_FAILURES.get(structure_key(problem), 0) >= SKIP_AFTER_FAILURES


def note_slicing(problem: Problem, found: bool) -> None:
    """Record how slicing fared on a diverse solve of `problem` (`slicing_known_to_fail`)."""
    if not problem.options.diverse:
        return
    key = structure_key(problem)
    if len(_SLICING_FAILURES) > 1024:  # a long-lived worker of many briefs
        _SLICING_FAILURES.clear()
    if found:
        _SLICING_FAILURES[key] = -1
    elif _SLICING_FAILURES.get(key, 0) >= 0:
        _SLICING_FAILURES[key] = _SLICING_FAILURES.get(key, 0) + 1


@dataclass
class _Row:
    region: Box  # the rectangle of free floor the row is a band of
    band: Box  # the row as planned; the QP then sets its height
    rooms: list[Room] = field(default_factory=list)


def slicing_has_demands(problem: Problem) -> bool:
    """Whether rooms are coupled (adjacency) or tied to the outline (boundary)."""
    return bool(problem.adjacency) or any(room.boundary for room in problem.rooms)


def slicing_applies(problem: Problem) -> bool:
    """Slicing honours sizes, aspect ratios and guide points at any size; adjacency and
    boundary demands up to `DEMANDS_UP_TO` rooms (the row search is a Python annealing),
    a tree of doors up to `DOOR_TREE_UP_TO`."""
    rooms = len(problem.rooms)
    if not slicing_has_demands(problem):
        return True
    door_tree = len(problem.adjacency) >= DOOR_TREE_SHARE * rooms
    return rooms <= (DOOR_TREE_UP_TO if door_tree else DEMANDS_UP_TO)


def slicing_layout(
    problem: Problem, domain: Domain, *, deadline: float, seed: int = 0
) -> dict[str, Box] | None:
    """One rectangle per room filling the free floor, with the least E_size among a
    few row plans; None when no plan found admits the rooms' bounds and demands."""
    regions = _floor_regions(problem, domain)
    if not regions:
        return None
    # The side of a room with no target nor maximum: the floor shared out evenly.
    typical = math.sqrt(sum(r.area for r in regions) / len(problem.rooms))
    demands = Demands.of(problem, domain)
    if demands:
        return _slice_with_demands(problem, regions, demands, typical,
                                   rng=random.Random(seed), deadline=deadline)
    best: tuple[float, dict[str, Box]] | None = None
    for shift in ROW_TRIES:
        if time.monotonic() >= deadline:
            break
        rows = _plan_rows(problem, regions, shift, typical)
        if rows is None:
            continue
        solved = size_rows(_as_plan(regions, rows), typical, deadline=deadline)
        if solved is not None and (best is None or solved[0] < best[0]):
            best = solved
    return None if best is None else best[1]


def _slice_with_demands(
    problem: Problem, regions: list[Box], demands: Demands, typical: float,
    *, rng: random.Random, deadline: float,
) -> dict[str, Box] | None:
    """Anneal row plans until every demand can hold (solver/heuristics/row_search.py), size each
    such plan with the QP; the best of the first `PLANS_WANTED` that size wins."""
    rows = _plan_rows(problem, regions, 0, typical)
    if rows is None:
        return None
    plan = _as_plan(regions, rows)
    target = {r.id: aimed_size(r, typical) for r in problem.rooms}
    best: tuple[float, dict[str, Box]] | None = None
    found = 0
    rooms = len(problem.rooms)
    base, e_base = plan, math.inf
    while time.monotonic() < deadline and found < PLANS_WANTED:
        plan = anneal_rows(plan, demands, target, rng=rng, deadline=deadline,
                           moves=ANNEAL_PATIENCE * rooms)
        if sizeable(plan, demands):
            solved = size_rows(plan, typical, deadline=deadline, demands=demands)
            if solved is not None:
                found += 1
                if best is None or solved[0] < best[0]:
                    best = solved
        # Basin hopping: shake the best plan so far for the next annealing.
        e_plan = energy(plan, demands, target)
        if e_plan < e_base:
            base, e_base = plan, e_plan
        plan = kicked(base, rng, moves=max(2, rooms // KICK_SHARE))
    return None if best is None else best[1]


def _floor_regions(problem: Problem, domain: Domain) -> list[Box]:
    """The free floor as rectangles that can each hold a room, bottom to top. A guide
    point that no such rectangle holds (one in a sliver beside an aisle's notch, as in
    a part of a large layout: bench/NOTES.md, "Parts that would not slice, and a second
    level-1 search") gets the largest rectangle around it first, the rest of the floor
    is cut as before: its room can then be sliced into a row that reaches the point."""
    kept: list[Box] = []
    while True:
        rest = domain.free.difference(shapely.union_all([b.to_polygon() for b in kept]))
        regions = kept + [r for r in rectangles_of(rest)
                          if _can_host_a_room(problem.rooms, r)]
        stranded = (largest_box_around(rest, x, y) for room in problem.rooms
                    for x, y in room.positions
                    if not any(r.contains_point(x, y, tol=0) for r in regions))
        around = next((b for b in stranded
                       if b is not None and _can_host_a_room(problem.rooms, b)), None)
        if around is None:
            return sorted(regions, key=lambda b: (b.y0, b.x0))
        kept.append(around)


def _can_host_a_room(rooms: Sequence[Room], region: Box) -> bool:
    return any(size_bounds(r)[0][0] <= region.width and size_bounds(r)[1][0] <= region.depth
               for r in rooms)


def _plan_rows(
    problem: Problem, regions: list[Box], shift: int, typical: float
) -> list[_Row] | None:
    """Rows per region from the typical target depth (`shift` more or fewer), rooms
    dealt by area: pinned rooms to the row holding their points, the others deepest
    first so that rooms of one row want similar depths."""
    free_area = sum(r.area for r in regions)
    depth = statistics.median(aimed_size(r, typical)[1] for r in problem.rooms)
    rows: list[_Row] = []
    for region in regions:
        count = max(1, round(region.depth / depth) + shift)
        step = region.depth / count
        rows += [_Row(region, Box(region.x0, region.y0 + k * step, region.x1,
                                  region.y0 + (k + 1) * step))
                 for k in range(count)]
    loose: list[Room] = []
    for room in problem.rooms:
        if not room.positions:
            loose.append(room)
            continue
        homes = {i for i, row in enumerate(rows)
                 for x, y in room.positions if row.band.contains_point(x, y, tol=0)}
        if len(homes) == 1:
            rows[homes.pop()].rooms.append(room)
        else:  # points in two planned rows: dealt like the others, the QP decides
            loose.append(room)
    # Rooms fill the floor in proportion to their targets.
    area = sum(math.prod(aimed_size(r, typical)) for r in problem.rooms)
    scale = free_area / area if area > 0 else 1.0
    # The deepest rooms into the deepest rows: a shallow band between obstacles takes
    # the rooms that want to be shallow.
    loose.sort(key=lambda r: -aimed_size(r, typical)[1])
    dealing = sorted(rows, key=lambda row: -row.band.depth)
    for index, row in enumerate(dealing):
        room_area = sum(math.prod(aimed_size(r, typical)) * scale for r in row.rooms)
        last = index == len(dealing) - 1
        while loose and (last or room_area + math.prod(aimed_size(loose[0], typical)) * scale / 2
                         <= row.band.area):
            room = loose.pop(0)
            row.rooms.append(room)
            room_area += math.prod(aimed_size(room, typical)) * scale
    _balance(rows, typical)
    rows = [row for row in rows if row.rooms]
    for row in rows:
        row.rooms = _order_along(row)
    return rows if rows else None


def _order_along(row: _Row) -> list[Room]:
    """The row's rooms by x: pinned rooms in the order of their points, the others
    spread evenly in the order they were dealt, each moved as little as it takes not
    to sit between two pinned rooms too close to let it in (measured: a part of a
    140-room mall had a shop dealt between two guide points 1.4 m apart, and no plan
    could be sized; bench/NOTES.md, "Parts that would not slice, and a second level-1
    search")."""
    loose = [r for r in row.rooms if not r.positions]
    step = row.band.width / max(1, len(loose))
    slot = {r.id: statistics.mean(x for x, _ in r.positions) if r.positions
            else row.band.x0 + (loose.index(r) + 0.5) * step for r in row.rooms}
    order = sorted((r for r in row.rooms if r.positions), key=lambda r: slot[r.id])
    for room in loose:
        wanted = sum(1 for r in order if slot[r.id] < slot[room.id])
        tries = sorted(range(len(order) + 1), key=lambda k: (abs(k - wanted), k))
        fitting = (k for k in tries
                   if _fits_along([*order[:k], room, *order[k:]], row.band))
        k = next(fitting, wanted)
        order.insert(k, room)
    return order


def _fits_along(rooms: Sequence[Room], band: Box) -> bool:
    """Whether rooms side by side in this order, each at its minimum width, can reach
    their guide points' x and stay within the band (a necessary test: maximum widths
    and depths are left to the QP)."""
    x = band.x0
    for room in rooms:
        xs = [px for px, _ in room.positions]
        if xs and min(xs) < x - 1e-9:
            return False
        x = max([x + size_bounds(room)[0][0], *xs])
    return x <= band.x1 + 1e-9


@dataclass
class _Tally:
    """A row's rooms as the sums its estimated E_size needs: count, widths, depths,
    squared depths; moving a room in or out is O(1)."""

    band: Box
    n: int = 0
    widths: float = 0.0
    depths: float = 0.0
    squares: float = 0.0

    def cost(self, n: int, widths: float, depths: float, squares: float) -> float:
        if n == 0:
            return 0.0 if self.band.area < MIN_ROW_AREA else self.band.width ** 2
        h = self.band.depth
        misfit = widths - self.band.width
        return misfit ** 2 / n + n * h * h - 2 * h * depths + squares

    def now(self) -> float:
        return self.cost(self.n, self.widths, self.depths, self.squares)

    def changed(self, out: tuple[float, float] | None, into: tuple[float, float] | None
                ) -> float:
        """The cost with the room of target `out` taken out and `into` put in."""
        n, widths, depths, squares = self.n, self.widths, self.depths, self.squares
        for sign, target in ((-1, out), (1, into)):
            if target is not None:
                n += sign
                widths += sign * target[0]
                depths += sign * target[1]
                squares += sign * target[1] ** 2
        return self.cost(n, widths, depths, squares)

    def apply(self, out: tuple[float, float] | None, into: tuple[float, float] | None
              ) -> None:
        for sign, target in ((-1, out), (1, into)):
            if target is not None:
                self.n += sign
                self.widths += sign * target[0]
                self.depths += sign * target[1]
                self.squares += sign * target[1] ** 2


def _balance(rows: list[_Row], typical: float) -> None:
    """Hill-climb the dealing: move or swap loose rooms between rows while that lowers
    an estimate of E_size with the rows at their planned depths, a row's width misfit
    spread evenly over its rooms (what the QP would do with it)."""
    target = {r.id: aimed_size(r, typical) for row in rows for r in row.rooms}
    tallies = [_Tally(row.band) for row in rows]
    for row, tally in zip(rows, tallies, strict=True):
        for room in row.rooms:
            tally.apply(None, target[room.id])
    for _ in range(BALANCE_PASSES):
        improved = False
        for a, row_a in enumerate(rows):
            for room in [r for r in row_a.rooms if not r.positions]:
                mine = target[room.id]
                cost_a = tallies[a].now()
                best: tuple[float, int, Room | None] = (1e-9, -1, None)
                for b, row_b in enumerate(rows):
                    if b == a:
                        continue
                    base = cost_a + tallies[b].now()
                    # Move the room to row b, or swap it with one of b's loose rooms.
                    gain = base - tallies[a].changed(mine, None) - tallies[b].changed(None, mine)
                    if gain > best[0]:
                        best = (gain, b, None)
                    for other in row_b.rooms:
                        if other.positions:
                            continue
                        theirs = target[other.id]
                        gain = (base - tallies[a].changed(mine, theirs)
                                - tallies[b].changed(theirs, mine))
                        if gain > best[0]:
                            best = (gain, b, other)
                _, b, other = best
                if b < 0:
                    continue
                row_b = rows[b]
                row_a.rooms = [r for r in row_a.rooms if r is not room]
                row_b.rooms = [r for r in row_b.rooms if r is not other]
                row_b.rooms.append(room)
                theirs = None if other is None else target[other.id]
                if other is not None:
                    row_a.rooms.append(other)
                tallies[a].apply(mine, theirs)
                tallies[b].apply(theirs, mine)
                improved = True
        if not improved:
            return


def _as_plan(regions: list[Box], rows: list[_Row]) -> RowPlan:
    """The dealt rows grouped by their rectangle of floor, bottom to top, a room a
    column."""
    by_region: dict[Box, list[_Row]] = {region: [] for region in regions}
    for row in rows:
        by_region[row.region].append(row)
    return RowPlan(regions, [[[[room] for room in row.rooms]
                              for row in sorted(rs, key=lambda r: r.band.y0)]
                             for rs in by_region.values()])
