"""The stochastic search Peng et al. compare their IP against (Sec. 5.4, Fig. 12): start
from every edge active and, step by step, delete one edge, a pair of adjacent edges or a
triple of consecutive edges, or add one edge back; every feasible move is ranked by the
network's value and one is picked, the better ranked the likelier, ever more greedily as
the time runs out (simulated annealing on the rank). Judged by `measure.judge`, the same
as any network. A baseline for the bench, not used by the product."""

from __future__ import annotations

import random
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace

from floorplan.solver.network.formulation import Feature, NetworkSpec, pair_paths
from floorplan.solver.network.measure import Judgement, judge
from floorplan.solver.network.mesh import Mesh
from floorplan.solver.network.start import cover_sets, routes_held


@dataclass(frozen=True)
class SearchResult:
    edges: list[int]
    judgement: Judgement
    steps: int
    seconds: float


def judge_spec(spec: NetworkSpec, edges: list[int],
               covers: list[list[int]] | None = None) -> Judgement:
    """`judge` of `edges` against everything `spec` asks of a network, forbidden
    too-close pairs (Eq. 12) included."""
    verdict = judge(
        spec.mesh,
        edges,
        spec.sinks,
        reach=spec.coverage,
        max_distance=spec.max_distance,
        dead_end=spec.dead_end,
        lambda_length=spec.lambda_length,
        lambda_distance=spec.lambda_distance,
        covers=covers,
        faces=spec.faces_covered,
        join=spec.join_sinks,
    )
    if spec.too_close is Feature.FORBID and verdict.valid:
        chosen = set(edges)
        if any(a in chosen and b in chosen for a, b in spec.mesh.opposite):
            return replace(verdict, valid=False)
    if spec.point_pairs and verdict.valid and not routes_held(_routes(spec), set(edges)):
        return replace(verdict, valid=False)
    return verdict


_ROUTES: dict[int, tuple[NetworkSpec, list[list[list[int]]]]] = {}


def _routes(spec: NetworkSpec) -> list[list[list[int]]]:
    """`pair_paths` of `spec`, kept for the spec a search judges over and over."""
    kept = _ROUTES.get(id(spec))
    if kept is None or kept[0] is not spec:
        _ROUTES.clear()
        kept = _ROUTES[id(spec)] = (spec, pair_paths(spec))
    return kept[1]


def _moves(mesh: Mesh, incident: list[list[int]], active: set[int]) -> Iterator[frozenset[int]]:
    """Edge sets to toggle: single edges (delete or add), adjacent pairs and consecutive
    triples of active edges (delete)."""
    for x in range(len(mesh.edges)):
        yield frozenset((x,))
    for x in active:
        for v in mesh.edges[x]:
            for y in incident[v]:
                if y > x and y in active:
                    yield frozenset((x, y))
                    far = mesh.other(y, v)
                    for z in incident[far]:
                        if z not in (x, y) and z in active:
                            yield frozenset((x, y, z))


def stochastic_search(
    spec: NetworkSpec, *, time_limit: float, seed: int = 0, start: list[int] | None = None
) -> SearchResult:
    """The best valid network found within `time_limit` seconds, from every edge active
    (the paper's trivial solution) or from `start`."""
    started = time.monotonic()
    rng = random.Random(seed)
    mesh = spec.mesh
    incident = mesh.incident()
    current = set(range(len(mesh.edges))) if start is None else set(start)
    best_edges = sorted(current)
    covers = cover_sets(spec)
    best = judge_spec(spec, best_edges, covers)
    steps = 0
    while time.monotonic() - started < time_limit:
        ranked: list[tuple[float, list[int]]] = []
        for move in set(_moves(mesh, incident, current)):
            if time.monotonic() - started >= time_limit:
                break
            adding = len(move) == 1 and next(iter(move)) not in current
            if len(move) > 1 and not move <= current:
                continue
            trial = sorted(current | move if adding else current - move)
            verdict = judge_spec(spec, trial, covers)
            if verdict.valid:
                ranked.append((verdict.value, trial))
        if not ranked:
            break
        ranked.sort(key=lambda r: r[0])
        # Rank-based annealing: early on any of the better half may be taken, at the end
        # almost always the best.
        heat = max(0.0, 1.0 - (time.monotonic() - started) / time_limit)
        pick = min(
            len(ranked) - 1, int(rng.random() ** (1 + 8 * (1 - heat)) * len(ranked) * 0.5 * heat)
        )
        current = set(ranked[pick][1])
        steps += 1
        verdict = judge_spec(spec, ranked[pick][1], covers)
        if verdict.value < best.value or not best.valid:
            best, best_edges = verdict, ranked[pick][1]
    return SearchResult(best_edges, best, steps, time.monotonic() - started)
