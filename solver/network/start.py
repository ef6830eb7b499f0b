"""A first network for SCIP to start from (as the MIQP hands SCIP its starts): the whole
mesh less its stubs to the outline, pruned edge by edge, farthest from the sinks first,
while it stays valid (`measure.judge`); then every variable of the IP in closed form."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from floorplan.solver.network.formulation import (
    Feature,
    NetworkModel,
    NetworkSpec,
    last_leg,
    pair_paths,
)
from floorplan.solver.network.measure import distances, judge
from floorplan.solver.network.mesh import Mesh
from floorplan.solver.network.repair import repaired_network


def greedy_network(
    spec: NetworkSpec, *, prune: bool = True, repair_seconds: float = 0.0
) -> list[int] | None:
    """A valid network, or None when neither the pruned mesh nor a comb is one, nor
    `repair.repaired_network` makes one of the combs within `repair_seconds` (then SCIP
    starts cold)."""
    mesh = spec.mesh
    incident = mesh.incident()
    sink_set = set(spec.sinks)
    # A vertex with a single mesh edge is a stub (on the outline): a dead end if used.
    edges = [
        x
        for x, (i, j) in enumerate(mesh.edges)
        if all(v in sink_set or len(incident[v]) > 1 for v in (i, j))
    ]

    routes = pair_paths(spec)

    def ok(trial: Sequence[int]) -> bool:
        chosen = set(trial)
        if spec.too_close is Feature.FORBID and any(
            a in chosen and b in chosen for a, b in mesh.opposite
        ):
            return False
        if not routes_held(routes, chosen):
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
            faces=spec.faces_covered,
            join=spec.join_sinks,
        ).valid

    covers = cover_sets(spec)
    candidates = [edges] if ok(edges) else []
    if not candidates:
        # The whole mesh breaks a rule (too-close edges): try combs of lines instead,
        # each with the shortest path of every route.
        combs = [sorted(set(c).union(*(p[0] for p in routes if p))) for c in comb_networks(spec)]
        candidates = sorted(
            (c for c in combs if ok(c)), key=lambda c: sum(mesh.lengths[x] for x in c)
        )
        if not candidates and repair_seconds > 0:
            fixed = repaired_network(spec, combs, time_limit=repair_seconds)
            candidates = [fixed] if fixed is not None and ok(fixed) else []
    fitted = (_fit_distances(spec, c, ok) for c in candidates)
    found = next((c for c in fitted if c is not None), None)
    if found is None:
        return None
    edges = found
    if not prune:
        return edges
    reach = distances(mesh, edges, spec.sinks)
    order = sorted(edges, key=lambda x: -max(reach.get(v, 0.0) for v in mesh.edges[x]))
    current = set(edges)
    for x in order:
        trial = sorted(current - {x})
        if ok(trial) and _distances_fit(spec, trial):
            current.discard(x)
    return sorted(current)


def routes_held(routes: Sequence[Sequence[Sequence[int]]], chosen: set[int]) -> bool:
    """Every pair of Eq. 7-8 has one of its paths (`formulation.pair_paths`) wholly in
    `chosen`."""
    return all(any(all(x in chosen for x in p) for p in paths) for paths in routes)


def comb_networks(spec: NetworkSpec) -> list[list[int]]:
    """Candidate networks that keep two cells between parallel corridors: grid lines every
    second row (or column) across the floor, cross lines every k-th column (row), and
    from each sink a straight run inwards to the first line it meets."""
    mesh = spec.mesh
    cell = {(_at(mesh.xs, p[0]), _at(mesh.ys, p[1])): v for v, p in enumerate(mesh.points)}
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
                        for t in range(along):
                            a, b = ((t, r), (t + 1, r)) if horizontal else ((r, t), (r, t + 1))
                            if (x := edge(a, b)) is not None:
                                chosen.add(x)
                    for c in sorted({*range(first, along, k), along - first}):
                        for t in range(rows[0] if rows else 0, rows[-1] if rows else 0):
                            a, b = ((c, t), (c, t + 1)) if horizontal else ((t, c), (t + 1, c))
                            if (x := edge(a, b)) is not None:
                                chosen.add(x)
                    out.append(sorted(chosen | _sink_runs(mesh, spec.sinks, chosen)))
    return out


def _at(lines: Sequence[float], value: float) -> int:
    """The index of the grid line at `value`."""
    return min(range(len(lines)), key=lambda k: abs(lines[k] - value))


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


def half_edge_values(
    mesh: Mesh, edges: Sequence[int], sinks: Sequence[int]
) -> dict[tuple[int, int], float]:
    """The active half-edges of the network `edges` and their distance values, in closed
    form: on a shortest-walk tree to the sinks each vertex v hands over to its parent n,
    T(v) = D_{v->n} = 0 when n is a sink, else length(v, n) + T(n); every other edge
    runs towards its end of smaller T, with D = its length + T of that end (0 into a
    sink). Eq. 1-4 then hold with L on each half-edge's tree successor."""
    reach = distances(mesh, edges, sinks)
    chosen = set(edges)
    incident = mesh.incident()
    lengths = mesh.lengths
    sink_set = set(sinks)
    parent: dict[int, int] = {}
    for v, d in reach.items():
        if v in sink_set:
            continue
        parent[v] = min(
            (
                mesh.other(x, v)
                for x in incident[v]
                if x in chosen
                and abs(reach.get(mesh.other(x, v), math.inf) + lengths[x] - d) < 1e-6
            ),
            key=lambda n: reach[n],
        )
    length_of = {mesh.edges[x]: lengths[x] for x in chosen}

    def size(a: int, b: int) -> float:
        return length_of[(min(a, b), max(a, b))]

    tail: dict[int, float] = {s: 0.0 for s in sink_set}
    for v in sorted(parent, key=lambda v: reach[v]):
        n = parent[v]
        tail[v] = 0.0 if n in sink_set else size(v, n) + tail[n]
    out: dict[tuple[int, int], float] = {}
    for x in chosen:
        i, j = mesh.edges[x]
        if i not in tail or j not in tail:
            continue
        options = []
        for a, b in ((i, j), (j, i)):
            if b in sink_set:
                options.append((0.0, (a, b)))
            elif parent.get(b) != a:
                options.append((lengths[x] + tail[b], (a, b)))
        if options:
            value, half = min(options)
            out[half] = value
    for v, n in parent.items():
        out[(v, n)] = tail[v]
    return out


def _fit_distances(
    spec: NetworkSpec, edges: list[int], ok: Callable[[Sequence[int]], bool]
) -> list[int] | None:
    """`edges` less the edges whose distance value exceeds the IP's bound (an edge
    between two far ends of the network: each direction walks on past the other end),
    largest first, as long as the network stays valid; None when that does not do."""
    current = list(edges)
    mesh = spec.mesh
    for _ in range(len(edges)):
        if _distances_fit(spec, current):
            return current
        longest = last_leg(spec)
        values = half_edge_values(mesh, current, spec.sinks)
        worst = sorted(
            (
                (d, (min(a, b), max(a, b)))
                for (a, b), d in values.items()
                if d
                > (spec.max_distance or 0.0)
                - longest
                + math.dist(mesh.points[a], mesh.points[b]) / 2
                + 1e-9
            ),
            reverse=True,
        )
        index = {e: x for x, e in enumerate(mesh.edges)}
        for _d, pair in worst:
            trial = [x for x in current if x != index[pair]]
            if ok(trial):
                current = trial
                break
        else:
            return None
    return None


def _distances_fit(spec: NetworkSpec, edges: Sequence[int]) -> bool:
    """The closed-form distance values keep within the IP's bound (`travel_cap`)."""
    if spec.max_distance is None:
        return True
    values = half_edge_values(spec.mesh, edges, spec.sinks)
    longest = last_leg(spec)

    def bound(a: int, b: int) -> float:
        return (
            (spec.max_distance or 0.0)
            - longest
            + math.dist(spec.mesh.points[a], spec.mesh.points[b]) / 2
        )

    covered = {
        x for x, e in enumerate(spec.mesh.edges) if e in {(min(a, b), max(a, b)) for a, b in values}
    }
    return covered >= set(edges) and all(d <= bound(a, b) + 1e-9 for (a, b), d in values.items())


def start_values(nm: NetworkModel, edges: Sequence[int]) -> dict[str, float]:
    """Every variable's value for the network `edges` (`half_edge_values`; L on each
    active half-edge's successor of smaller distance value, flows on fewest-edge paths)."""
    spec, mesh = nm.spec, nm.spec.mesh
    chosen = set(edges)
    incident = mesh.incident()
    active = half_edge_values(mesh, edges, spec.sinks)
    values: dict[str, float] = {}
    for x, (i, j) in enumerate(mesh.edges):
        values[nm.E[x].name] = float(x in chosen)
        for a, b in ((i, j), (j, i)):
            values[nm.H[(a, b)].name] = float((a, b) in active)
            values[nm.D[(a, b)].name] = active.get((a, b), 0.0)
    for var in nm.L.values():
        values[var.name] = 0.0
    for (i, j), d in active.items():
        successors = [
            (active[(j, k)], k)
            for k in (mesh.other(x, j) for x in incident[j])
            if k != i
            and (j, k) in active
            and (i, j, k) in nm.L
            and active[(j, k)] <= d - math.dist(mesh.points[i], mesh.points[j]) + 1e-9
        ]
        if successors:
            values[nm.L[(i, j, min(successors)[1])].name] = 1.0
    for v, var in nm.V.items():
        values[var.name] = float(any(x in chosen for x in incident[v]))
    for (x, j), var in nm.T.items():
        rest = [y for y in incident[j] if y != x]
        values[var.name] = float(x not in chosen and all(y in chosen for y in rest))
    if nm.F:
        for var in nm.F.values():
            values[var.name] = 0.0
        for target in spec.sinks[1:]:
            for a, b in _path(mesh, incident, chosen, spec.sinks[0], target):
                values[nm.F[(a, b)].name] += 1.0
    for key, var in nm.P.items():
        values[var.name] = float(all(x in chosen for x in nm.paths[key]))
    for k, var in nm.Z.items():
        a, b = mesh.opposite[k]
        values[var.name] = float(a in chosen and b in chosen)
    return values


def _path(
    mesh: Mesh, incident: list[list[int]], chosen: set[int], source: int, target: int
) -> list[tuple[int, int]]:
    """The half-edges of a fewest-edge path from `source` to `target` over `chosen`."""
    came: dict[int, int] = {source: source}
    frontier = [source]
    while frontier and target not in came:
        nxt = []
        for v in frontier:
            for x in incident[v]:
                w = mesh.other(x, v)
                if x in chosen and w not in came:
                    came[w] = v
                    nxt.append(w)
        frontier = nxt
    if target not in came:
        return []
    out, here = [], target
    while here != source:
        out.append((came[here], here))
        here = came[here]
    return out[::-1]
