"""A first network where the closed-form combs (`start.comb_networks`) all break a rule:
a min-conflicts search that toggles one mesh edge at a time, taking the toggle that
leaves the fewest broken rules (too-close pairs, uncovered cells, islands, sinks unreached
or apart, dead ends over the cap, edges past the travel cap), with a short tabu list so it
does not undo its last steps. Its result is judged like any network (`measure.judge`);
SCIP then improves it. On an anisotropic grid (rooms' widths along x, depths along y,
bench/NOTES.md "Corridors") no comb was valid on office-154 or mall-140 and SCIP alone
found no network in 20 s."""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Sequence

from floorplan.solver.network.formulation import Feature, NetworkSpec, pair_paths
from floorplan.solver.network.mesh import Mesh

#: Toggles remembered and not undone.
TABU = 12


class _Graph:
    """The mesh's lookups computed once (the search evaluates thousands of networks)."""

    def __init__(self, mesh: Mesh, routes: list[list[list[int]]] | None = None) -> None:
        self.mesh = mesh
        self.routes = routes or []
        self.lengths = mesh.lengths
        self.incident = mesh.incident()
        self.ends = mesh.edges
        self.pitch = max(min(mesh.pitch), 1e-6)


def conflicts(spec: NetworkSpec, graph: _Graph, chosen: set[int]) -> float:
    """How badly `chosen` breaks the spec's rules: one per broken item (a too-close
    pair, an uncovered cell, an island vertex, an unreached sink, an edge past the
    travel cap, a dead end over the cap plus its excess in cells); 0 for a valid
    network."""
    mesh, lengths = spec.mesh, graph.lengths
    bad = 0.0
    if spec.too_close is Feature.FORBID:
        bad += sum(1 for a, b in mesh.opposite if a in chosen and b in chosen)
    if spec.faces_covered:
        bad += sum(1 for sides in mesh.faces if not any(x in chosen for x in sides))
    adjacent: dict[int, list[tuple[int, float]]] = {}
    for x in chosen:
        i, j = graph.ends[x]
        adjacent.setdefault(i, []).append((j, lengths[x]))
        adjacent.setdefault(j, []).append((i, lengths[x]))
    reached = _walks(adjacent, spec.sinks)
    bad += sum(1 for v in adjacent if v not in reached)
    bad += 2 * sum(1 for s in spec.sinks if s not in adjacent)
    if spec.join_sinks and len(spec.sinks) > 1:
        one = _walks(adjacent, spec.sinks[:1])
        bad += 2 * sum(1 for s in spec.sinks[1:] if s not in one)
    if spec.max_distance is not None:
        for x in chosen:
            i, j = graph.ends[x]
            walk = min(reached.get(i, math.inf), reached.get(j, math.inf)) + lengths[x] / 2
            if math.isfinite(walk) and walk > spec.max_distance + 1e-9:
                bad += 1
    if spec.dead_end is not None:
        for length in _dead_ends(graph, adjacent, chosen, set(spec.sinks)):
            if length > spec.dead_end + 1e-9:
                bad += 1 + (length - spec.dead_end) / graph.pitch
    # A route (Eq. 7-8) counts the edges its nearest admissible path lacks.
    for paths in graph.routes:
        bad += min((sum(1 for x in p if x not in chosen) for p in paths), default=0)
    return bad


def repaired_network(
    spec: NetworkSpec, starts: Sequence[Sequence[int]], *, time_limit: float
) -> list[int] | None:
    """A valid network reached from the least broken of `starts` by single-edge toggles
    within `time_limit` seconds, or None."""
    if not starts:
        return None
    began = time.monotonic()
    graph = _Graph(spec.mesh, pair_paths(spec))
    scored = sorted((conflicts(spec, graph, set(s)), sorted(s)) for s in starts)
    bad, edges = scored[0]
    current = set(edges)
    tabu: list[int] = []
    everything = range(len(spec.mesh.edges))
    while bad > 0 and time.monotonic() - began < time_limit:
        best: tuple[float, float, int] | None = None
        for x in everything:
            if x in tabu:
                continue
            current ^= {x}
            score = conflicts(spec, graph, current)
            current ^= {x}
            # Ties go to removing (a shorter network) before adding.
            key = (score, 0.0 if x in current else graph.lengths[x], x)
            if best is None or key < best:
                best = key
        if best is None:
            break
        bad, _, x = best
        current ^= {x}
        tabu = [*tabu, x][-TABU:]
    return sorted(current) if bad == 0 else None


def _walks(adjacent: dict[int, list[tuple[int, float]]], sinks: Sequence[int]) -> dict[int, float]:
    """Dijkstra from the sinks over the chosen edges."""
    best: dict[int, float] = {}
    queue = [(0.0, s) for s in sinks if s in adjacent]
    while queue:
        d, v = heapq.heappop(queue)
        if v in best:
            continue
        best[v] = d
        for w, length in adjacent[v]:
            if w not in best:
                heapq.heappush(queue, (d + length, w))
    return best


def _dead_ends(
    graph: _Graph, adjacent: dict[int, list[tuple[int, float]]], chosen: set[int],
    sinks: set[int],
) -> list[float]:
    """As `measure.dead_ends`, on the precomputed lookups."""
    out = []
    for tip, around in adjacent.items():
        if len(around) != 1 or tip in sinks:
            continue
        here, came, length = tip, -1, 0.0
        for _ in range(len(chosen)):
            step = next(x for x in graph.incident[here] if x in chosen and x != came)
            length += graph.lengths[step]
            here, came = graph.mesh.other(step, here), step
            if here in sinks or len(adjacent[here]) != 2:
                break
        out.append(length)
    return out
