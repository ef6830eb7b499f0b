"""What a chosen network does, measured on the graph alone (no model values): walking
distances to the sinks, islands, uncovered vertices, dead ends, and the network's value
under Eq. 14 with the least distance values its edges admit. Used by the stochastic search
and to judge any network, the IP's included."""

from __future__ import annotations

import heapq
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from floorplan.solver.network.mesh import Mesh


def distances(mesh: Mesh, edges: Iterable[int], sinks: Sequence[int]) -> dict[int, float]:
    """Walking distance along `edges` from each vertex they reach to the nearest sink
    (Dijkstra from the sinks); vertices on no path to a sink are absent."""
    lengths = mesh.lengths
    adjacent: dict[int, list[tuple[int, float]]] = {}
    for x in edges:
        i, j = mesh.edges[x]
        adjacent.setdefault(i, []).append((j, lengths[x]))
        adjacent.setdefault(j, []).append((i, lengths[x]))
    best: dict[int, float] = {}
    queue = [(0.0, s) for s in sinks]
    while queue:
        d, v = heapq.heappop(queue)
        if v in best:
            continue
        best[v] = d
        for w, length in adjacent.get(v, ()):
            if w not in best:
                heapq.heappush(queue, (d + length, w))
    return best


def active_vertices(mesh: Mesh, edges: Iterable[int]) -> set[int]:
    return {v for x in edges for v in mesh.edges[x]}


def islands(mesh: Mesh, edges: Sequence[int], sinks: Sequence[int]) -> set[int]:
    """Active vertices no walk along the network joins to a sink."""
    reached = distances(mesh, edges, sinks)
    return active_vertices(mesh, edges) - set(reached)


def uncovered(mesh: Mesh, edges: Sequence[int], reach: float) -> list[int]:
    """Vertices farther than `reach` from every active vertex (Eq. 6 violated)."""
    active = [mesh.points[v] for v in active_vertices(mesh, edges)]
    return [
        v
        for v, p in enumerate(mesh.points)
        if not any(math.dist(p, q) <= reach + 1e-9 for q in active)
    ]


def dead_ends(mesh: Mesh, edges: Sequence[int], sinks: Sequence[int]) -> list[float]:
    """Length of every dead end: from a tip (non-sink vertex of one active edge) along
    vertices of two active edges to the first junction or sink."""
    chosen = set(edges)
    incident = mesh.incident()
    lengths = mesh.lengths
    sink_set = set(sinks)
    degree = {v: sum(1 for x in incident[v] if x in chosen) for v in range(len(mesh.points))}
    out = []
    for tip, deg in degree.items():
        if deg != 1 or tip in sink_set:
            continue
        here, came, length = tip, -1, 0.0
        while True:
            step = next(x for x in incident[here] if x in chosen and x != came)
            length += lengths[step]
            here, came = mesh.other(step, here), step
            if here in sink_set or degree[here] != 2:
                break
        out.append(length)
    return out


@dataclass(frozen=True)
class Judgement:
    valid: bool
    length: float
    distance_sum: float
    max_distance: float
    value: float  # Eq. 14's length and distance terms


def joined(mesh: Mesh, edges: Sequence[int], sinks: Sequence[int]) -> bool:
    """All sinks in one piece of the network."""
    if len(sinks) < 2:
        return True
    return all(s in distances(mesh, edges, sinks[:1]) for s in sinks[1:])


def judge(
    mesh: Mesh,
    edges: Sequence[int],
    sinks: Sequence[int],
    *,
    reach: float | None,
    max_distance: float | None,
    dead_end: float | None,
    lambda_length: float,
    lambda_distance: float,
    covers: Sequence[Sequence[int]] | None = None,
    faces: bool = False,
    join: bool = False,
) -> Judgement:
    """Validity (no island, coverage of vertices and, with `faces`, of cells, sinks
    reached and, with `join`, in one piece, caps) and Eq. 14's value with each
    active edge carrying the least distance value Eq. 2 admits in its better direction
    (walk from its far end to a sink, none for an edge into a sink). `covers`: per
    vertex, the vertices within `reach`, when the caller has them (a search judging many
    networks)."""
    lengths = mesh.lengths
    reached = distances(mesh, edges, sinks)
    active = active_vertices(mesh, edges)
    if reach is None:
        covered = True
    elif covers is not None:
        covered = all(any(u in active for u in near) for near in covers)
    else:
        covered = not uncovered(mesh, edges, reach)
    chosen = set(edges)
    if faces and not all(any(x in chosen for x in sides) for sides in mesh.faces):
        covered = False
    if join and not joined(mesh, edges, sinks):
        covered = False
    valid = not (active - set(reached)) and all(s in active for s in sinks) and covered
    # The walk from the middle of each active edge (the travel cap's measure).
    far = max(
        (
            min(reached.get(i, math.inf), reached.get(j, math.inf)) + lengths[x] / 2
            for x in edges
            for i, j in [mesh.edges[x]]
        ),
        default=0.0,
    )
    if max_distance is not None and far > max_distance + 1e-9:
        valid = False
    if dead_end is not None and any(d > dead_end + 1e-9 for d in dead_ends(mesh, edges, sinks)):
        valid = False
    sink_set = set(sinks)
    total = 0.0
    for x in edges:
        i, j = mesh.edges[x]
        if i in sink_set or j in sink_set:
            continue
        total += min(reached.get(i, math.inf), reached.get(j, math.inf))
    length = sum(lengths[x] for x in edges)
    value = lambda_length * length + lambda_distance * total
    return Judgement(valid, length, total, far, value)
