"""A first network for SCIP to start from (as the MIQP hands SCIP its starts): the whole
mesh less its stubs to the outline, pruned edge by edge, farthest from the sinks first,
while it stays valid (`measure.judge`); then every variable of the IP in closed form."""

from __future__ import annotations

import heapq
from collections.abc import Sequence

from floorplan.solver.network.formulation import Feature, NetworkModel, NetworkSpec
from floorplan.solver.network.measure import distances, judge
from floorplan.solver.network.mesh import Mesh


def greedy_network(spec: NetworkSpec, *, prune: bool = True) -> list[int] | None:
    """A valid network, or None when the pruned mesh is not one (then SCIP starts cold)."""
    mesh = spec.mesh
    incident = mesh.incident()
    sink_set = set(spec.sinks)
    # A vertex with a single mesh edge is a stub (on the outline): a dead end if used.
    edges = [
        x
        for x, (i, j) in enumerate(mesh.edges)
        if all(v in sink_set or len(incident[v]) > 1 for v in (i, j))
    ]

    def ok(trial: Sequence[int]) -> bool:
        if spec.too_close is Feature.FORBID:
            chosen = set(trial)
            if any(a in chosen and b in chosen for a, b in mesh.opposite):
                return False
        return judge(
            mesh,
            trial,
            spec.sinks,
            reach=spec.coverage,
            max_distance=spec.max_distance,
            dead_end=spec.dead_end,
            lambda_length=1.0,
            lambda_distance=0.0,
            covers=covers,
        ).valid

    covers = cover_sets(spec)
    if not ok(edges):
        # The whole mesh breaks a rule (too-close edges): try combs of lines instead.
        combs = [c for c in comb_networks(spec) if ok(c)]
        if not combs:
            return None
        edges = min(combs, key=lambda c: sum(mesh.lengths[x] for x in c))
    if not prune:
        return edges
    reach = distances(mesh, edges, spec.sinks)
    order = sorted(edges, key=lambda x: -max(reach.get(v, 0.0) for v in mesh.edges[x]))
    current = set(edges)
    for x in order:
        trial = sorted(current - {x})
        if ok(trial):
            current.discard(x)
    return sorted(current)


def comb_networks(spec: NetworkSpec) -> list[list[int]]:
    """Candidate networks that keep two cells between parallel corridors: grid lines every
    second row (or column) across the floor, cross lines every k-th column (row), and
    from each sink a straight run inwards to the first line it meets."""
    mesh = spec.mesh
    px, py = mesh.pitch
    x0 = min(p[0] for p in mesh.points)
    y0 = min(p[1] for p in mesh.points)
    cell = {
        (round((p[0] - x0) / px), round((p[1] - y0) / py)): v for v, p in enumerate(mesh.points)
    }
    nx = max(i for i, _ in cell)
    ny = max(j for _, j in cell)
    index = {e: x for x, e in enumerate(mesh.edges)}

    def edge(a: tuple[int, int], b: tuple[int, int]) -> int | None:
        if a not in cell or b not in cell:
            return None
        return index.get((min(cell[a], cell[b]), max(cell[a], cell[b])))

    def lines(n: int, offset: int) -> list[int]:
        at = list(range(offset, n, 2))
        if at and n - 1 - at[-1] >= 2:
            at.append(n - 1)
        return at

    out: list[list[int]] = []
    for horizontal in (True, False):
        along, across = (nx, ny) if horizontal else (ny, nx)
        for offset in (1, 2):
            rows = lines(across, offset)
            for k in (2, 3, 4, 6, 8):
                for first in range(1, min(k, along)):
                    chosen: set[int] = set()
                    for r in rows:
                        for t in range(1, along - 1):
                            a, b = ((t, r), (t + 1, r)) if horizontal else ((r, t), (r, t + 1))
                            if (x := edge(a, b)) is not None:
                                chosen.add(x)
                    for c in range(first, along, k):
                        for t in range(rows[0] if rows else 0, rows[-1] if rows else 0):
                            a, b = ((c, t), (c, t + 1)) if horizontal else ((t, c), (t + 1, c))
                            if (x := edge(a, b)) is not None:
                                chosen.add(x)
                    out.append(sorted(chosen | _sink_runs(mesh, spec.sinks, chosen)))
    return out


def _sink_runs(mesh: Mesh, sinks: Sequence[int], chosen: set[int]) -> set[int]:
    """From each sink, the edges of a straight run inwards to the first vertex of
    `chosen` (none when the run meets none)."""
    incident = mesh.incident()
    on = {v for x in chosen for v in mesh.edges[x]}
    runs: set[int] = set()
    for s in sinks:
        for first in incident[s]:
            path, here, step = [], s, first
            while True:
                path.append(step)
                there = mesh.other(step, here)
                if there in on:
                    runs.update(path)
                    break
                dx = mesh.points[there][0] - mesh.points[here][0]
                dy = mesh.points[there][1] - mesh.points[here][1]
                step = next(
                    (
                        y
                        for y in incident[there]
                        if y != step
                        and abs(
                            (mesh.points[mesh.other(y, there)][0] - mesh.points[there][0]) * dy
                            - (mesh.points[mesh.other(y, there)][1] - mesh.points[there][1]) * dx
                        )
                        < 1e-9
                    ),
                    -1,
                )
                if step < 0:
                    break
                here = there
            else:
                continue
    return runs


def cover_sets(spec: NetworkSpec) -> list[list[int]] | None:
    """Per vertex, the vertices within the coverage range (Eq. 6's sets)."""
    if spec.coverage is None:
        return None
    pts = spec.mesh.points
    r2 = (spec.coverage + 1e-9) ** 2
    return [
        [u for u, q in enumerate(pts) if (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 <= r2] for p in pts
    ]


def start_values(nm: NetworkModel, edges: Sequence[int]) -> dict[str, float]:
    """Every variable's value for the network `edges`: each edge oriented towards its end
    nearer a sink in hops, distance values the hops times the longest edge (so each falls
    by at least the edge's length along the hand-over), L on a shortest hop path."""
    spec, mesh = nm.spec, nm.spec.mesh
    longest = max(mesh.lengths)
    chosen = set(edges)
    incident = mesh.incident()
    hops: dict[int, int] = {}
    queue = [(0, s) for s in spec.sinks]
    while queue:
        h, v = heapq.heappop(queue)
        if v in hops:
            continue
        hops[v] = h
        for x in incident[v]:
            if x in chosen:
                heapq.heappush(queue, (h + 1, mesh.other(x, v)))
    values: dict[str, float] = {}
    sink_set = set(spec.sinks)
    for x, (i, j) in enumerate(mesh.edges):
        on = x in chosen
        values[nm.E[x].name] = float(on)
        towards = (
            (i, j)
            if (on and hops.get(j, 0) < hops.get(i, 0))
            or (on and hops.get(j, 0) == hops.get(i, 0) and j in sink_set)
            else (j, i)
        )
        for a, b in ((i, j), (j, i)):
            active = on and (a, b) == towards
            values[nm.H[(a, b)].name] = float(active)
            values[nm.D[(a, b)].name] = hops.get(b, 0) * longest if active else 0.0
    for (i, j, k), var in nm.L.items():
        values[var.name] = float(
            values[nm.H[(i, j)].name] > 0.5
            and values[nm.H[(j, k)].name] > 0.5
            and hops.get(k, 0) < hops.get(j, 0)
        )
    for v, var in nm.V.items():
        values[var.name] = float(any(x in chosen for x in incident[v]))
    for (x, j), var in nm.T.items():
        rest = [y for y in incident[j] if y != x]
        values[var.name] = float(x not in chosen and all(y in chosen for y in rest))
    for k, var in nm.Z.items():
        a, b = mesh.opposite[k]
        values[var.name] = float(a in chosen and b in chosen)
    return values
