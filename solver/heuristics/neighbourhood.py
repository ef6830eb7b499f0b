"""Large-neighbourhood search on one level: free a few rooms around a gap, hold the
others where they are, re-solve. SCIP's branch-and-bound on the full model improves
the incumbent slowly (big-M disjunctions relax weakly), while the MIQP of five free
rooms among fixed walls solves in a fraction of a second and may move, swap or
resize them, which the grow-only refinement levels cannot."""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import shapely

from floorplan.solver.geometry import Box, Domain, bounding_box, unusable_space
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import LevelResult, LevelStatus, add_start
from floorplan.solver.miqp.spec import LevelSpec, level_objective

#: Rooms freed per neighbourhood at first ...
NEIGHBOURHOOD_SIZE = 5
#: ... and at most, as failed steps widen it.
MAX_NEIGHBOURHOOD_SIZE = 10
#: Seconds one neighbourhood solve may take at most.
STEP_LIMIT = 0.5
#: Relative objective gain below which a step counts as no improvement.
MIN_GAIN = 1e-6
#: Uncovered parts smaller than this (m²) do not attract a neighbourhood.
GAP_AREA = 1e-3
#: A mover may be this much (metres) larger than the gap: it pushes its neighbours.
MOVER_REACH = 0.5

Step = Callable[[LevelModel, float], LevelResult]


@dataclass(frozen=True)
class Incumbent:
    rects: dict[str, Box]
    objective: float
    steps: int = 0
    improvements: int = 0


def search_neighbourhoods(
    spec: LevelSpec,
    rects: dict[str, Box],
    domain: Domain,
    *,
    deadline: float,
    rng: random.Random,
    step: Step,
    should_stop: Callable[[], bool] | None = None,
    keep_coverage: bool = False,
    patience: int | None = None,
    on_improvement: Callable[[dict[str, Box]], None] | None = None,
    good_enough: Callable[[dict[str, Box]], bool] | None = None,
    stall_seconds: float | None = None,
) -> Incumbent:
    """Improve the layout `rects` of the one-rectangle-per-room level `spec` until
    `deadline`, until `patience` steps in a row or `stall_seconds` improved nothing, or
    until an incumbent is `good_enough`; each accepted step lowers Eq. 12 (under `spec`'s
    weights) and, with `keep_coverage`, covers no less of the domain."""
    best = Incumbent(dict(rects), level_objective(spec, rects))
    coverage = covered_area(domain, best.rects)
    size = NEIGHBOURHOOD_SIZE
    min_sizes = {r.name: r.min_size for r in spec.rects}
    partners = _partners(spec)
    tried: set[frozenset[str]] = set()  # neighbourhoods already optimal for this incumbent
    since_improvement = 0
    last_gain = time.monotonic()
    while time.monotonic() < deadline - 0.05 and not (should_stop and should_stop()):
        if (patience is not None and since_improvement >= patience) or (
                good_enough is not None and since_improvement == 0
                and good_enough(best.rects)) or (
                stall_seconds is not None and time.monotonic() - last_gain > stall_seconds):
            break
        free, gap = choose_neighbourhood(best.rects, domain, rng, size=size,
                                         around_gap=best.steps % 3 != 2, min_sizes=min_sizes,
                                         partners=partners)
        if frozenset(free) in tried:
            if size >= len(rects):
                break  # every neighbourhood of every size is exhausted
            size += 1
            continue
        candidate, result = _solve_neighbourhood(spec, best.rects, free, gap, deadline, step)
        objective = level_objective(spec, candidate)
        gain = best.objective - objective
        improved = result.rects is not None and gain > MIN_GAIN * max(1.0, abs(best.objective))
        if improved and keep_coverage:
            improved, coverage = _keeps_coverage(domain, candidate, coverage)
        best = Incumbent(candidate if improved else best.rects,
                         objective if improved else best.objective,
                         best.steps + 1, best.improvements + int(improved))
        since_improvement = 0 if improved else since_improvement + 1
        last_gain = time.monotonic() if improved else last_gain
        if improved:
            tried.clear()
            size = NEIGHBOURHOOD_SIZE
            if on_improvement is not None:
                on_improvement(best.rects)
        else:
            # Solved to optimality, or cut off by the step's limit without a gain: the
            # same rooms from the same incumbent would give the same answer again (a
            # floor of at most ten rooms re-solved whole three times over, at 0.5 s each).
            tried.add(frozenset(free))
            # A local optimum for this size: look wider.
            size = min(size + 1, MAX_NEIGHBOURHOOD_SIZE, len(rects))
        if result.status is LevelStatus.INTERRUPTED:
            break
    return best


def _keeps_coverage(domain: Domain, candidate: dict[str, Box],
                    coverage: float) -> tuple[bool, float]:
    """Whether `candidate` covers no less than `coverage` (within a gap's area), and the
    coverage to hold later steps to."""
    now = covered_area(domain, candidate)
    kept = now >= coverage - GAP_AREA
    return kept, max(coverage, now) if kept else coverage


def _partners(spec: LevelSpec) -> dict[str, set[str]]:
    """Each rectangle's contact partners: freed together, a contact can move."""
    partners: dict[str, set[str]] = {}
    for c in spec.contacts:
        for name in c.members:
            partners.setdefault(name, set()).update(c.members - {name})
    return partners


def _solve_neighbourhood(
    spec: LevelSpec, rects: dict[str, Box], free: set[str], gap: tuple[Box, ...],
    deadline: float, step: Step,
) -> tuple[dict[str, Box], LevelResult]:
    """One step: the rectangles `free` (and the `gap` they may grow into) re-solved with
    everything else fixed; the layout with the step's result, and that result."""
    sub = neighbourhood_spec(spec, rects, free, extra=gap)
    lm = build_level(sub)
    limit = min(STEP_LIMIT, deadline - time.monotonic())
    # The layout as it stands is the step's start, in closed form: refused only when a
    # constraint of the step's model breaks at it (then the step is that answer).
    start = add_start(lm, {r.name: rects[r.name] for r in sub.rects if r.fixed is None})
    result = step(lm, limit - start.seconds) if start.values is not None else start
    candidate = dict(rects)
    if result.rects is not None:
        candidate.update({n: b for n, b in result.rects.items() if n in free})
    return candidate, result


def covered_area(domain: Domain, rects: dict[str, Box]) -> float:
    """Area of the free domain the rectangles cover."""
    union = shapely.union_all([b.to_polygon() for b in rects.values()])
    return float(domain.free.intersection(union).area)


def coverage_first(spec: LevelSpec) -> LevelSpec:
    """`spec` with a linear growth term of weight lambda_cover added to Eq. 12
    (`LevelSpec.growth_weight`): growth into gaps then outweighs size error, and the
    search leaves local optima in which a small gap was cheaper than a larger room.
    Linear, so the objective stays convex; it grows rooms along their own shape,
    where raising lambda_cover to 2 lambda_size would also push every room square."""
    return replace(spec, growth_weight=spec.cover_weight)


def neighbourhood_spec(
    spec: LevelSpec, rects: dict[str, Box], free: set[str], extra: tuple[Box, ...] = ()
) -> LevelSpec:
    """`spec` with only the `free` rooms placed: every other room is a blocked box, and
    held as a fixed rectangle where a contact of a free room names it."""
    partners = {n for c in spec.contacts if c.members & free
                for n in c.members} - free
    # A room of several rectangles keeps its envelope while any of them moves, with its
    # other rectangles held where they are.
    envelopes = tuple(e for e in spec.envelopes if set(e.rects) & free)
    partners |= {n for e in envelopes for n in e.rects} - free
    kept = []
    for r in spec.rects:
        if r.name in free:
            kept.append(r)
        elif r.name in partners:
            kept.append(replace(r, fixed=rects[r.name]))
    contacts = tuple(c for c in spec.contacts if c.members & free)
    # The free rooms rearrange within the box they span with the gap near them: a
    # smaller box means fewer disjunctions and smaller big-M values.
    region = _clip(bounding_box([rects[n] for n in free] + list(extra)), spec.region)
    settled = [rects[r.name] for r in spec.rects if r.name not in free]
    inside = [_clip(b, region) for b in (*spec.blocked, *settled) if _overlaps(b, region)]
    smallest = min(min(r.min_size) for r in spec.rects if r.name in free)
    blocked = unusable_space(region, inside, smallest)
    return replace(spec, name=f"{spec.name}/lns", region=region, rects=tuple(kept),
                   contacts=contacts, envelopes=envelopes, blocked=blocked)


def _clip(b: Box, region: Box) -> Box:
    return Box(max(b.x0, region.x0), max(b.y0, region.y0),
               min(b.x1, region.x1), min(b.y1, region.y1))


def _overlaps(a: Box, b: Box) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def choose_neighbourhood(
    rects: dict[str, Box],
    domain: Domain,
    rng: random.Random,
    *,
    size: int,
    around_gap: bool,
    min_sizes: dict[str, tuple[float, float]] | None = None,
    partners: dict[str, set[str]] | None = None,
) -> tuple[set[str], tuple[Box, ...]]:
    """The `size` rooms nearest to a gap (a random one, weighted by area) with the gap's
    box, or the rooms nearest to a random room. Around a gap, half the time a room
    from anywhere whose minimum size fits the gap joins in: a pocket beside a shaft
    is often filled only by a small room moving in."""
    centre, extra = None, ()
    if around_gap:
        gaps = domain.gaps(rects.values(), GAP_AREA)
        if gaps:
            centre = rng.choices(gaps, weights=[g.area for g in gaps])[0]
            extra = (Box(*centre.bounds),)
    if centre is None:
        centre = rects[rng.choice(sorted(rects))].to_polygon()
    by_distance = sorted(rects, key=lambda r: (rects[r].to_polygon().distance(centre), r))
    # The nearest rooms, and now and then a random further one to escape local optima.
    chosen = set(by_distance[:size])
    if len(by_distance) > size and rng.random() < 0.3:
        chosen.discard(by_distance[size - 1])
        chosen.add(rng.choice(by_distance[size:]))
    if extra and min_sizes and rng.random() < 0.5:
        gap = extra[0]
        fitting = [r for r in by_distance[size:] if r not in chosen
                   and min_sizes[r][0] <= gap.width + MOVER_REACH
                   and min_sizes[r][1] <= gap.depth + MOVER_REACH]
        if fitting:
            mover = rng.choice(fitting)
            # The rooms it must touch come along, or it could not move at all.
            chosen |= {mover} | (partners or {}).get(mover, set())
    return chosen, extra
