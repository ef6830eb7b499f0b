"""Design variants (docs/problem.md, "Design variants"): up to `options.variants` valid
layouts of one problem, pairwise different in topology, ranked by Eq. 12.

The topology of a layout is its adjacency graph: the pairs of rooms sharing at least
`TOPOLOGY_CONTACT` metres of wall. The first layout is solved as usual (the time
limit, the seed); then further searches run, each with a share of up to twice that
time again, and a layout joins the variants when it is valid and its graph differs
from every one found before; the search goes on until it has enough that cover at
least 99 % of the floor (or as much as the first), and variants covering less only
make up the number when time runs out. Other seeds alone seldom change the topology (the MIQP
of a small floor has one best arrangement), so on a single floor without regions each
further search also *demands* one wall that no variant found so far has: a hard
adjacency between two rooms that are near each other in the best layout but do not
touch (nearest pairs first). Whatever it finds then differs from every variant before,
and is a layout of the problem as asked (a constraint was added, none removed); its
report is made again for that problem (`solver.pipeline.fixed.relaid`). The variants are ranked by
`report.objective` (Eq. 12 plus the soft shortfalls), best first; the best is the
answer itself. Each variant's report says how far its graph is from every other's
(`VariantInfo.difference`: the share of adjacencies in one graph and not the other).

Sub-problems (the floors of a building, the regions) are solved with `variants` 1: the
variants are of the whole answer.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable

from shapely.geometry import Polygon

from floorplan.models import Adjacency, Layout, Problem, VariantInfo
from floorplan.solver.events import EventSink, Phase, SolveEvent, StopFlag
from floorplan.solver.geometry import shared_wall_length
from floorplan.solver.pipeline.fixed import relaid
from floorplan.solver.pipeline.regions import regions_apply
from floorplan.solver.pipeline.storeys import job_time_limit
from floorplan.solver.pipeline.subdomains import SubdomainExecutor

#: Two rooms are neighbours in the topology when they share this much wall (metres).
TOPOLOGY_CONTACT = 0.9
#: The whole search for k variants takes at most this many times one layout's limit.
VARIANT_TIME_FACTOR = 3.0
#: A further search is not started with less than this share of one layout's limit left.
MIN_ATTEMPT_SHARE = 0.15
#: Further searches tried per variant asked, at most.
ATTEMPTS_PER_VARIANT = 3
#: Variants cover at least this share of the free area, or as much as the first layout
#: when that covers less: the search goes on until it has enough of those, and others
#: (with holes) only make up the number when it does not.
MIN_VARIANT_COVERAGE = 0.99
#: Rooms further apart than this (metres) in the best layout are not asked to touch.
MAX_GAP = 4.0
#: Seeds of further searches: the problem's seed plus multiples of this.
SEED_STEP = 7919

Solver = Callable[..., Layout]
Graph = frozenset[tuple[str, str]]


def variant_time_factor(problem: Problem) -> float:
    """How many times one layout's time limit the job may take: `VARIANT_TIME_FACTOR`
    with variants asked, else 1."""
    return VARIANT_TIME_FACTOR if problem.options.variants > 1 else 1.0


def topology(layout: Layout) -> Graph:
    """The pairs of rooms sharing at least `TOPOLOGY_CONTACT` m of wall, each pair
    sorted; with floors, rooms are named '<floor>/<room>'."""
    groups = ([("", layout.rooms)] if layout.floors is None
              else [(f"{f.id}/", f.rooms) for f in layout.floors])
    pairs: set[tuple[str, str]] = set()
    for prefix, rooms in groups:
        shapes = [(prefix + r.id, Polygon(r.polygon)) for r in rooms if len(r.polygon) >= 3]
        for (a, pa), (b, pb) in itertools.combinations(shapes, 2):
            if shared_wall_length(pa, pb) >= TOPOLOGY_CONTACT:
                pairs.add((a, b) if a < b else (b, a))
    return frozenset(pairs)


def difference(a: Graph, b: Graph) -> float:
    """The share of adjacencies in one graph and not the other, over those in either.

    >>> difference(frozenset({("a", "b"), ("b", "c")}), frozenset({("a", "b"), ("a", "c")}))
    0.6667
    >>> difference(frozenset(), frozenset())
    0.0
    """
    union = a | b
    return round(len(a ^ b) / len(union), 4) if union else 0.0


def usable(layout: Layout) -> bool:
    """A layout that may be a variant: valid, with rooms."""
    return layout.report.valid and bool(layout.all_rooms)


def solve_variants(
    problem: Problem,
    *,
    solve: Solver,
    on_event: EventSink | None = None,
    should_stop: StopFlag | None = None,
    subdomains: SubdomainExecutor | None = None,
) -> Layout:
    """Up to `options.variants` distinct valid layouts of `problem`, ranked; the best
    is returned with all of them in `variants`."""
    started = time.monotonic()
    wanted = problem.options.variants
    limit = job_time_limit(problem)
    one = problem.with_options(variants=1, time_limit=limit)
    first = solve(one, on_event=on_event, should_stop=should_stop, subdomains=subdomains)
    if not usable(first):
        return first
    found: list[tuple[Layout, Graph, int]] = [(first, topology(first), problem.options.seed)]
    announce(on_event, started, first, f"variant 1 found, {wanted} asked (seed "
             f"{problem.options.seed})")
    deadline = started + VARIANT_TIME_FACTOR * limit
    coverage_floor = min(first.report.coverage, MIN_VARIANT_COVERAGE)
    pairs = iter(missing_walls(problem, first)) if problem.floors is None and not regions_apply(
        problem) else None
    share = max(limit * (VARIANT_TIME_FACTOR - 1) / max(wanted - 1, 1),
                MIN_ATTEMPT_SHARE * limit)
    stopped = should_stop or (lambda: False)
    for attempt in range(1, ATTEMPTS_PER_VARIANT * (wanted - 1) + 1):
        left = deadline - time.monotonic()
        covering = [f for f in found if f[0].report.coverage >= coverage_floor]
        if len(covering) >= wanted or left < MIN_ATTEMPT_SHARE * limit or stopped():
            break
        seed = (problem.options.seed + attempt * SEED_STEP) % 2**31
        asked = one.with_options(seed=seed, time_limit=min(share, left))
        pair = next(pairs, None) if pairs is not None else None
        if pair is not None:
            while pair is not None and any(pair in g for _, g, _ in found):
                pair = next(pairs, None)
            if pair is not None:
                extra = Adjacency(a=pair[0], b=pair[1], min_contact=TOPOLOGY_CONTACT)
                asked = asked.model_copy(update={"adjacency": [*asked.adjacency, extra]})
        layout = solve(asked, should_stop=should_stop, subdomains=subdomains)
        if not usable(layout):
            continue
        if pair is not None:
            layout = relaid(one, layout)
            if not usable(layout):
                continue
        graph = topology(layout)
        if any(graph == g for _, g, _ in found):
            continue
        found.append((layout, graph, seed))
        announce(on_event, started, layout,
                 f"variant {len(found)} found, {wanted} asked (seed {seed})")
    # Those covering enough first; those with holes only to make up the number.
    found.sort(key=lambda f: f[0].report.coverage < coverage_floor)
    return ranked(found[:wanted], elapsed=time.monotonic() - started)


def announce(on_event: EventSink | None, started: float, layout: Layout, detail: str) -> None:
    """Tell `on_event` (if any) that a variant was found."""
    if on_event is not None:
        on_event(SolveEvent(phase=Phase.VARIANT, level=0, elapsed=time.monotonic() - started,
                            objective=layout.report.objective, detail=detail))


def missing_walls(problem: Problem, layout: Layout) -> list[tuple[str, str]]:
    """Pairs of rooms of a single-floor `layout` that share less than `TOPOLOGY_CONTACT`
    of wall, nearest first (ties by name), at most `MAX_GAP` apart; not two fixed
    rooms (their contact cannot change)."""
    fixed = {room.id for room in problem.rooms if room.fixed is not None}
    shapes = [(r.id, Polygon(r.polygon)) for r in layout.rooms
              if len(r.polygon) >= 3]
    graph = topology(layout)
    near = []
    for (a, pa), (b, pb) in itertools.combinations(shapes, 2):
        pair = (a, b) if a < b else (b, a)
        gap = pa.distance(pb)
        if pair not in graph and gap <= MAX_GAP and not {a, b} <= fixed:
            near.append((round(gap, 3), pair))
    return [pair for _, pair in sorted(near)]


def ranked(found: list[tuple[Layout, Graph, int]], *, elapsed: float) -> Layout:
    """The best of `found` by Eq. 12, with every one of them in `variants`, best first,
    each report saying where it stands."""
    order = sorted(found, key=lambda f: (f[0].report.objective
                                          if f[0].report.objective is not None
                                          else float("inf")))
    graphs = [g for _, g, _ in order]
    variants = []
    for i, (layout, graph, seed) in enumerate(order):
        diffs = [difference(graph, g) for g in graphs]
        others = [d for j, d in enumerate(diffs) if j != i]
        info = VariantInfo(index=i, seed=seed, adjacencies=sorted(graph), difference=diffs,
                           least_difference=min(others) if others else None)
        variants.append(layout.model_copy(update={
            "variants": None, "report": layout.report.model_copy(update={"variant": info})}))
    best = variants[0]
    report = best.report.model_copy(update={"solve_time": elapsed})
    return best.model_copy(update={"report": report, "variants": variants})
