"""Design variants (docs/problem.md, "Design variants"): up to `options.variants` valid
layouts of one problem, pairwise different in topology, ranked by Eq. 12.

The topology of a layout is its adjacency graph: the pairs of rooms sharing at least
`TOPOLOGY_CONTACT` metres of wall. The first layout is solved as usual (the time
limit, the seed). Other seeds alone seldom change the topology (the MIQP of a small
floor has one best arrangement), so each further variant *demands* one wall that no
variant found so far has: a hard adjacency between two rooms that are near each other
in the first layout but do not touch (nearest pairs first). Whatever it finds then
differs from every variant before, and is a layout of the problem as asked (a
constraint was added, none removed); its report is made again for that problem
(`solver.pipeline.fixed.relaid`).

On a single floor without regions a further variant is a *local re-layout* of the first
layout: the demanded pair and the rooms around it (`free_rooms`, `LOCAL_ROOMS` in all)
are laid out again and every other room is held where the first layout has it, as an
edit (`solver.pipeline.edit`: `Room.fixed`, the first layout as `options.start`), which
ends as soon as it covers its floor: about a second each, where a whole solve took
the first layout's time again. A local variant joins when it is valid and at least
`MIN_LOCAL_DIFFERENCE` of its graph differs from every variant's (one moved wall is no
design alternative); its report says `stalled` without a bound, the optimum of one
neighbourhood's MIQP being no proof for the whole. The local re-layouts end after
`LOCAL_MISSES` in a row found nothing new (on some floors the edit finds no layout in
its second: residential-15); whole solves with a wall demanded then get what they left,
one at a time. All further variants together take at most as long as the first layout
took (the job at most `LOCAL_TIME_FACTOR` times the limit). In a building or with
regions each further variant is a whole solve with another seed, with a share of up to
`VARIANT_TIME_FACTOR` - 1 times the limit.

A layout joins the variants when it is valid and its graph differs from every one
found before; the search goes on until it has enough that cover at least 99 % of the
floor (or as much as the first), and variants covering less only make up the number
when time runs out. The variants are ranked by `report.objective` (Eq. 12 plus the
soft shortfalls), best first; the best is the answer itself. Each variant's report says
how far its graph is from every other's (`VariantInfo.difference`: the share of
adjacencies in one graph and not the other).

Sub-problems (the floors of a building, the regions) are solved with `variants` 1: the
variants are of the whole answer.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable

from shapely import shortest_line
from shapely.geometry import Polygon

from floorplan.models import Adjacency, Layout, Problem, Termination, VariantInfo
from floorplan.models.options import StartRect, StartRoom
from floorplan.solver.events import EventSink, Phase, SolveEvent, StopFlag
from floorplan.solver.geometry import shared_wall_length
from floorplan.solver.pipeline.edit import solve_edit
from floorplan.solver.pipeline.fixed import edit_layout, fixed_boxes, relaid, start_boxes
from floorplan.solver.pipeline.regions import regions_apply
from floorplan.solver.pipeline.storeys import job_time_limit
from floorplan.solver.pipeline.subdomains import SubdomainExecutor

#: Two rooms are neighbours in the topology when they share this much wall (metres).
TOPOLOGY_CONTACT = 0.9
#: Rounding in a shared wall's length (metres): a wall demanded at `TOPOLOGY_CONTACT`
#: comes back as 0.8999999999999999 m.
CONTACT_TOLERANCE = 1e-6
#: The whole search for k variants takes at most this many times one layout's limit ...
VARIANT_TIME_FACTOR = 3.0
#: ... or this many on a single floor without regions, where further variants are local
#: re-layouts of the first (and at most as long as the first took, `solve_variants`).
LOCAL_TIME_FACTOR = 2.0
#: Seconds kept, from the further variants' time and from a whole solve's limit, for
#: what comes after the last solve (its layout checked again for the problem as asked,
#: the variants ranked): house-13's fourth variant from a whole solve ended 0.13 s past
#: twice one layout's time without them.
AFTER_SOLVE = 0.4
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
#: A local variant lays out again at most this many rooms (the pair made to touch and
#: their nearest neighbours); the others stay where the first layout has them.
LOCAL_ROOMS = 6
#: A local variant is kept only when its topology differs from every variant's by this
#: much (`difference`): a variant that moved one wall is no design alternative.
MIN_LOCAL_DIFFERENCE = 0.1
#: Local re-layouts end after this many in a row found no new variant (on some floors
#: the edit finds none: residential-15), leaving the time to whole solves.
LOCAL_MISSES = 5
#: Time limit of a local variant's solve (seconds): its edit ends sooner when it covers.
LOCAL_SECONDS = 2.0
#: Seeds of further searches: the problem's seed plus multiples of this.
SEED_STEP = 7919

Solver = Callable[..., Layout]
Graph = frozenset[tuple[str, str]]


def local_variants_apply(problem: Problem) -> bool:
    """Whether further variants of `problem` are local re-layouts of the first: on a
    single floor without regions (elsewhere they are whole solves)."""
    return problem.floors is None and not regions_apply(problem)


def variant_time_factor(problem: Problem) -> float:
    """How many times one layout's time limit the job may take: with variants asked,
    `LOCAL_TIME_FACTOR` where they are local re-layouts, else `VARIANT_TIME_FACTOR`;
    1 without."""
    if problem.options.variants == 1:
        return 1.0
    return LOCAL_TIME_FACTOR if local_variants_apply(problem) else VARIANT_TIME_FACTOR


def topology(layout: Layout) -> Graph:
    """The pairs of rooms sharing at least `TOPOLOGY_CONTACT` m of wall, each pair
    sorted; with floors, rooms are named '<floor>/<room>'."""
    groups = ([("", layout.rooms)] if layout.floors is None
              else [(f"{f.id}/", f.rooms) for f in layout.floors])
    pairs: set[tuple[str, str]] = set()
    for prefix, rooms in groups:
        shapes = [(prefix + r.id, Polygon(r.polygon)) for r in rooms if len(r.polygon) >= 3]
        for (a, pa), (b, pb) in itertools.combinations(shapes, 2):
            if shared_wall_length(pa, pb) >= TOPOLOGY_CONTACT - CONTACT_TOLERANCE:
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
    deadline = started + variant_time_factor(problem) * limit
    pairs = None
    if local_variants_apply(problem):
        # Further variants take as long as the first layout took (at least a local
        # search's time each), never past the job's bound.
        took = time.monotonic() - started
        deadline = min(deadline, started + took + max(took - AFTER_SOLVE,
                                                      (wanted - 1) * LOCAL_SECONDS))
        pairs = missing_walls(problem, first)
    coverage_floor = min(first.report.coverage, MIN_VARIANT_COVERAGE)
    stopped = should_stop or (lambda: False)

    def enough() -> bool:
        covering = [f for f in found if f[0].report.coverage >= coverage_floor]
        return len(covering) >= wanted or stopped()

    def add(layout: Layout, seed: int, how: str, least: float = 0.0) -> bool:
        """Keep `layout` when it is valid and its topology differs from every one found
        before (by more than `least`); whether it was kept."""
        if not usable(layout):
            return False
        graph = topology(layout)
        if any(graph == g or difference(graph, g) < least for _, g, _ in found):
            return False
        found.append((layout, graph, seed))
        announce(on_event, started, layout,
                 f"variant {len(found)} found, {wanted} asked ({how}, seed {seed})")
        return True

    tried: set[tuple[str, str]] = set()
    misses = 0  # local re-layouts in a row that found no new variant
    if pairs is not None:
        # Local re-layouts first: each a fraction of a whole solve.
        for pair in pairs:
            if (enough() or len(tried) >= ATTEMPTS_PER_VARIANT * (wanted - 1)
                    or misses >= LOCAL_MISSES or deadline - time.monotonic() < LOCAL_SECONDS):
                break
            if any(pair in g for _, g, _ in found):
                continue
            tried.add(pair)
            seed = (problem.options.seed + (len(tried)) * SEED_STEP) % 2**31
            free = free_rooms(first, pair)
            local = local_variant(one, first, free, pair, seed=seed, deadline=deadline,
                                  should_stop=should_stop)
            kept = local is not None and add(
                local, seed, f"{pair[0]}-{pair[1]} made to touch, {len(free)} rooms laid "
                "out again", least=MIN_LOCAL_DIFFERENCE)
            misses = 0 if kept else misses + 1
    # Whole solves with the time left, each demanding a wall no variant has (when
    # there is one) or with another seed.
    whole_pairs = iter([p for p in missing_walls(problem, first) if p not in tried]
                       if pairs is not None else [])
    for attempt in range(1, ATTEMPTS_PER_VARIANT * (wanted - 1) + 1):
        left = deadline - time.monotonic()
        if enough() or left < MIN_ATTEMPT_SHARE * limit:
            break
        seed = (problem.options.seed + (len(tried) + attempt) * SEED_STEP) % 2**31
        # After local re-layouts, what they left goes to one whole solve at a time (a
        # share of it would seldom cover); elsewhere each variant missing gets its share.
        missing = wanted - sum(f[0].report.coverage >= coverage_floor for f in found)
        share = left if pairs is not None else max(left / max(missing, 1),
                                                   MIN_ATTEMPT_SHARE * limit)
        asked = one.with_options(seed=seed,
                                 time_limit=max(0.1, min(share, left) - AFTER_SOLVE))
        pair = next(whole_pairs, None)
        while pair is not None and any(pair in g for _, g, _ in found):
            pair = next(whole_pairs, None)
        if pair is not None:
            extra = Adjacency(a=pair[0], b=pair[1], min_contact=TOPOLOGY_CONTACT)
            asked = asked.model_copy(update={"adjacency": [*asked.adjacency, extra]})
        layout = solve(asked, should_stop=should_stop, subdomains=subdomains)
        if usable(layout):
            add(relaid(one, layout) if pair is not None else layout, seed, "whole solve")
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


def free_rooms(layout: Layout, pair: tuple[str, str]) -> list[str]:
    """The rooms a local variant lays out again to make `pair` touch: the pair, then
    the rooms touching either of them (or lying on the line between them), those
    nearest that line first, `LOCAL_ROOMS` in all at most."""
    shapes = {r.id: Polygon(r.polygon) for r in layout.rooms if len(r.polygon) >= 3}
    graph = topology(layout)
    between = shortest_line(shapes[pair[0]], shapes[pair[1]])
    near = []
    for room_id, shape in shapes.items():
        if room_id in pair:
            continue
        touching = any(tuple(sorted((room_id, p))) in graph for p in pair)
        gap = shape.distance(between)
        if touching or gap <= TOPOLOGY_CONTACT:
            near.append((round(gap, 3), not touching, room_id))
    return [*pair, *(room_id for *_, room_id in sorted(near)[:LOCAL_ROOMS - 2])]


def local_problem(problem: Problem, layout: Layout, free: list[str],
                  pair: tuple[str, str], *, seed: int) -> Problem:
    """`problem` with `pair` made to touch and only the `free` rooms of `layout` free:
    every other room fixed at its polygon in `layout`, which is the free rooms' warm
    start (an edit, `solver.pipeline.edit`)."""
    polygons = {r.id: [list(p) for p in r.polygon] for r in layout.rooms}
    rooms = [room if room.id in free or room.fixed is not None
             else room.model_copy(update={"fixed": polygons[room.id]})
             for room in problem.rooms]
    extra = Adjacency(a=pair[0], b=pair[1], min_contact=TOPOLOGY_CONTACT)
    start = [StartRoom(id=r.id, rectangles=[
        StartRect(x=b.x, y=b.y, width=b.width, depth=b.depth) for b in r.rectangles])
        for r in layout.rooms]
    options = problem.options.model_copy(update={
        "seed": seed, "time_limit": LOCAL_SECONDS, "start": start, "variants": 1})
    return problem.model_copy(update={"rooms": rooms, "options": options,
                                      "adjacency": [*problem.adjacency, extra]})


def local_variant(problem: Problem, layout: Layout, free: list[str], pair: tuple[str, str],
                  *, seed: int, deadline: float,
                  should_stop: StopFlag | None = None) -> Layout | None:
    """A variant of `problem` (one layout, one floor) from `layout`: the `free` rooms laid
    out again around the others with `pair` made to touch, by the edit's MIQP alone
    (`solver.pipeline.edit.solve_edit`, at most `LOCAL_SECONDS` and never past
    `deadline`); None when it finds no valid layout. The whole pipeline around the fixed
    rooms, an edit's fallback, would take seconds where another pair takes one. The
    report is made for `problem` and says `stalled` without a bound: the optimum of one
    neighbourhood's MIQP is no proof for the whole."""
    started = time.monotonic()
    local = local_problem(problem, layout, free, pair, seed=seed)
    result = solve_edit(local, fixed_boxes(local), deadline=min(deadline, started + LOCAL_SECONDS),
                        start=start_boxes(local), should_stop=should_stop)
    edited = edit_layout(local, result, started, Termination.STALLED)
    if edited is None:
        return None
    variant = relaid(problem, edited)
    return variant.model_copy(update={"report": variant.report.model_copy(update={
        "termination": Termination.STALLED, "bound": None, "gap": None})})


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
