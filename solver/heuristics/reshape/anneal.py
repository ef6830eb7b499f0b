"""The reshaping's annealing: `reshape` runs it `RESTARTS` times from a layout and keeps
the best result that covers the floor and has no higher Eq. 12."""

from __future__ import annotations

import functools
import math
import random
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from shapely.geometry import Polygon, box
from shapely.geometry.base import BaseGeometry

from floorplan.models import Problem
from floorplan.solver.budget import significant_gain
from floorplan.solver.geometry import Box, Domain, rectangles_of
from floorplan.solver.heuristics.reshape.needs import (
    TOL,
    Cost,
    Rect,
    cost_floor,
    keeps_demands,
    room_needs,
    shape_cost,
    shape_of,
    shape_ok,
)
from floorplan.solver.heuristics.reshape.strips import (
    GAP,
    JOG,
    clean,
    covered,
    gaps,
    hull,
    neighbour_pairs,
    nest,
    strip_cuts,
    strip_extent,
)

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
#: The share of the floor a result must cover: the checker's goal with the pipeline's
#: margin (solver.verify.checker.COVERAGE_GOAL + solver.pipeline.run.COVER_MARGIN, both
#: above this layer).
COVER_GOAL = 0.9905
#: Margin (in cost) by which a strip's cost floor must exceed what the annealing allows
#: before it is refused unbuilt: the floor ignores the snapping of shapes to the grid.
BOUND_SLACK = 1e-4
#: Share of the steps tried that swap two rooms' floors.
SWAP_SHARE = 0.2
#: Share of the steps tried that nest a room in a corner of another (`nest`).
NEST_SHARE = 0.1


@dataclass(frozen=True)
class ReshapeResult:
    """The rooms after reshaping, the steps taken and the steps tried."""

    rooms: dict[str, list[Box]]
    steps: int
    candidates: int


def reshape(problem: Problem, domain: Domain, rooms: Mapping[str, Sequence[Box]], *,
            deadline: float, seed: int = 0,
            should_stop: Callable[[], bool] | None = None,
            on_progress: Callable[[], None] | None = None) -> ReshapeResult:
    """Lower Eq. 12 of a layout by moving strips of floor between neighbours (a gap
    counts as a neighbour that costs lambda_cover per m²), annealing until `deadline`
    (time.monotonic()), `RESTARTS` times from `rooms` with seeds drawn from `seed`, each
    with an equal share of the time left. Returns the best layout found that covers as
    much as the coverage goal asks and has no higher Eq. 12 than `rooms`; unchanged
    rooms as given. `on_progress` is called whenever the lowest Eq. 12 of the best
    states of all runs so far falls significantly (`solver.budget.significant_gain`):
    the stall rule of the solve then knows the reshaping is still gaining on what the
    answer is judged by (its area and corner terms only choose among such states)."""
    best: tuple[float, ReshapeResult] | None = None
    steps = candidates = 0
    lowest = math.inf

    def on_best(eq12: float) -> None:
        nonlocal lowest
        if on_progress is not None and lowest != math.inf and significant_gain(lowest, eq12):
            on_progress()
        lowest = min(lowest, eq12)

    for k in range(RESTARTS):
        left = deadline - time.monotonic()
        if left <= 0 or (should_stop is not None and should_stop()):
            break
        total, result = _anneal(problem, domain, rooms,
                                deadline=time.monotonic() + left / (RESTARTS - k),
                                seed=seed * RESTARTS + k, should_stop=should_stop,
                                on_best=on_best)
        steps += result.steps
        candidates += result.candidates
        if best is None or total < best[0] - TOL:
            best = (total, result)
    if best is None:
        return ReshapeResult({r: list(b) for r, b in rooms.items()}, 0, 0)
    return ReshapeResult(best[1].rooms, steps, candidates)


def _anneal(problem: Problem, domain: Domain, rooms: Mapping[str, Sequence[Box]], *,
            deadline: float, seed: int,
            should_stop: Callable[[], bool] | None,
            on_best: Callable[[float], None] | None = None) -> tuple[float, ReshapeResult]:
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

    def costs(room: str, shape: BaseGeometry) -> Cost:
        if room.startswith(GAP):
            return Cost(cover * shape.area, cover * shape.area)
        c = shape_cost(needs.get(room), shape)
        return Cost(size_weight * c.size, size_weight * c.total)

    def lowest(room: str, bounds: Rect | None, area: float) -> float:
        """The least `costs(room, shape).total` of a shape with these bounds and area."""
        if room.startswith(GAP):
            return cover * area
        return size_weight * cost_floor(needs.get(room), bounds, area)

    state.update(gaps(domain, state))
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
    pairs, into_rooms = neighbour_pairs(state)
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
            nested = nest(state, needs, pairs, rng, rectangles_in, within_allowed)
            if nested is None:
                continue
            moved = nested
        else:
            # Uncovered floor is the costliest: rooms grow into it half the time.
            a, b = rng.choice(into_rooms if into_rooms and rng.random() < 0.5 else pairs)
            if (a, b) not in strips:
                strips[a, b] = list(strip_cuts(state[a], state[b], needs.get(a),
                                                needs.get(b)))
            if not strips[a, b]:
                continue
            cut = rng.choice(strips[a, b])
            taken = strip_extent(rectangles_in(a), cut)
            if taken is None:
                continue
            # Most strips are refused: a floor under their cost from areas and bounding
            # boxes alone (the corners' price is left out) refuses them without shapely.
            area, strip_bounds, rest_bounds = taken
            if rest_bounds is None and not a.startswith(GAP):
                continue  # the strip would take the whole room
            if not within_allowed({
                    a: (rest_bounds, state[a].area - area),
                    b: (hull(state[b].bounds, strip_bounds), state[b].area + area)}):
                continue
            strip = state[a].intersection(box(*cut))
            if strip.area <= JOG * JOG:
                continue
            new_a = clean(state[a].difference(strip), a.startswith(GAP))
            new_b = clean(state[b].union(strip), b.startswith(GAP))
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
            state.update(gaps(domain, state))
            touched |= {r for r in state if r.startswith(GAP)}
            cost = {r: cost[r] if not r.startswith(GAP) else costs(r, p)
                    for r, p in state.items()}
        pairs, into_rooms = neighbour_pairs(state, touched, pairs)
        # A pair's strips depend on its two rooms alone (gaps are renumbered).
        strips = {(a, b): cuts for (a, b), cuts in strips.items()
                  if a not in moved and b not in moved
                  and not a.startswith(GAP) and not b.startswith(GAP)}
        total = sum(c.total for c in cost.values())
        if (total < best[0] - TOL and sum(c.size for c in cost.values()) <= start + TOL
                and covered(domain, state) >= goal):
            best = (total, dict(state))
            if on_best is not None:
                on_best(sum(c.size for c in cost.values()))
    final = {r: p for r, p in best[1].items() if not r.startswith(GAP)}
    changed = {r for r in final if not final[r].equals(shapes[r])}
    out = {r: list(boxes) for r, boxes in rooms.items()}
    for r in changed:
        out[r] = rectangles_of(final[r])
    return best[0], ReshapeResult(out, steps, candidates)
