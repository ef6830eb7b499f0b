"""The network IP (Peng et al. Sec. 4) on small meshes with the real SCIP: its networks
are checked by walks over the returned edges written here, not by the model's values;
networks breaking a proposition, fixed into the model, must be refused."""

from __future__ import annotations

import itertools
import math
from collections import deque

import pytest
from shapely.geometry import box

from floorplan.solver.network import Feature, Mesh, NetworkSpec, build_network, grid_mesh
from floorplan.solver.network.solve import NetworkStatus, solve_network
from floorplan.solver.network.stochastic import stochastic_search

TIME = 60.0


def _mesh(width: float, depth: float, pitch: float = 3.0) -> Mesh:
    return grid_mesh(box(0, 0, width, depth), pitch)


def _vertex(mesh: Mesh, point: tuple[float, float]) -> int:
    return next(v for v, p in enumerate(mesh.points) if math.dist(p, point) < 1e-6)


def _adjacent(mesh: Mesh, edges: list[int]) -> dict[int, list[tuple[int, float]]]:
    out: dict[int, list[tuple[int, float]]] = {}
    for x in edges:
        i, j = mesh.edges[x]
        length = math.dist(mesh.points[i], mesh.points[j])
        out.setdefault(i, []).append((j, length))
        out.setdefault(j, []).append((i, length))
    return out


def _reached(mesh: Mesh, edges: list[int], sinks: list[int]) -> set[int]:
    """Breadth-first from the sinks over the active edges."""
    adjacent = _adjacent(mesh, edges)
    seen = set(sinks)
    queue = deque(sinks)
    while queue:
        v = queue.popleft()
        for w, _ in adjacent.get(v, []):
            if w not in seen:
                seen.add(w)
                queue.append(w)
    return seen


def _walk(mesh: Mesh, edges: list[int], sinks: list[int]) -> dict[int, float]:
    """Shortest walk to a sink, by relaxing until nothing changes (Bellman-Ford)."""
    adjacent = _adjacent(mesh, edges)
    best = {s: 0.0 for s in sinks}
    changed = True
    while changed:
        changed = False
        for v, near in adjacent.items():
            for w, length in near:
                if w in best and best[w] + length < best.get(v, math.inf) - 1e-9:
                    best[v] = best[w] + length
                    changed = True
    return best


def _solve(spec: NetworkSpec) -> list[int]:
    result = solve_network(spec, time_limit=TIME)
    assert result.status in (NetworkStatus.OPTIMAL, NetworkStatus.FEASIBLE)
    assert result.edges
    return result.edges


def _refused(spec: NetworkSpec, edges: list[int]) -> bool:
    """SCIP finds no solution with exactly `edges` active."""
    nm = build_network(spec)
    chosen = set(edges)
    for x, var in nm.E.items():
        value = 1.0 if x in chosen else 0.0
        nm.model.chgVarLb(var, value)
        nm.model.chgVarUb(var, value)
    nm.model.hideOutput()
    nm.model.setParam("limits/time", TIME)
    nm.model.optimize()
    return nm.model.getStatus() == "infeasible"


def _edges_of(mesh: Mesh, *path: tuple[float, float]) -> list[int]:
    """The mesh edges along a polyline of grid points."""
    out = []
    for a, b in itertools.pairwise(path):
        steps = round(math.dist(a, b) / 3.0)
        for k in range(steps):
            p = (a[0] + (b[0] - a[0]) * k / steps, a[1] + (b[1] - a[1]) * k / steps)
            q = (a[0] + (b[0] - a[0]) * (k + 1) / steps, a[1] + (b[1] - a[1]) * (k + 1) / steps)
            ij = tuple(sorted((_vertex(mesh, p), _vertex(mesh, q))))
            out.append(mesh.edges.index(ij))
    return out


def test_no_island_survives_and_coverage_holds() -> None:
    """Prop. 4.2 and Eq. 6: one sink in a corner's side, coverage one pitch; every
    active vertex is joined to the sink and every vertex is within range of one."""
    mesh = _mesh(15, 12)
    sink = _vertex(mesh, (0, 6))
    spec = NetworkSpec(mesh, (sink,), coverage=3.0 + 1e-6)
    edges = _solve(spec)
    active = {v for x in edges for v in mesh.edges[x]}
    assert active <= _reached(mesh, edges, [sink])
    for p in mesh.points:
        assert any(math.dist(p, mesh.points[v]) <= 3.0 + 1e-6 for v in active), p


def test_a_network_with_an_island_is_refused() -> None:
    """Two pieces covering the floor, one not touching the sink: Eq. 1-3 refuse it, while
    the same pieces joined are accepted."""
    mesh = _mesh(12, 12)
    sink = _vertex(mesh, (0, 6))
    spec = NetworkSpec(mesh, (sink,), coverage=4.3)  # a cell's diagonal
    main = _edges_of(mesh, (0, 6), (3, 6), (3, 3), (3, 9))
    island = _edges_of(mesh, (9, 3), (9, 9))
    assert _refused(spec, main + island)
    bridge = _edges_of(mesh, (3, 6), (9, 6))
    assert not _refused(spec, main + island + bridge)


def test_a_loop_without_a_sink_is_refused() -> None:
    """The case plain degree rules miss (the paper's Fig. 4c): a ring away from the sink."""
    mesh = _mesh(12, 12)
    sink = _vertex(mesh, (0, 6))
    spec = NetworkSpec(mesh, (sink,))
    stub = _edges_of(mesh, (0, 6), (3, 6))
    ring = _edges_of(mesh, (6, 3), (9, 3), (9, 9), (6, 9), (6, 3))
    assert _refused(spec, stub + ring)


@pytest.mark.parametrize("cap", [0.0, 3.0])
def test_dead_ends_stay_within_the_cap(cap: float) -> None:
    """No dead end longer than the cap, measured by walking from each tip here; two
    exits on opposite sides and a cell's diagonal of coverage (the outline's vertices
    are reached from inside), so that a network without dead ends exists."""
    mesh = _mesh(15, 12)
    sinks = [_vertex(mesh, (0, 6)), _vertex(mesh, (15, 6))]
    spec = NetworkSpec(mesh, tuple(sinks), coverage=4.3, dead_end=cap)
    edges = _solve(spec)
    adjacent = _adjacent(mesh, edges)
    tips = [v for v, near in adjacent.items() if len(near) == 1 and v not in sinks]
    for tip in tips:
        length, here, came = 0.0, tip, -1
        while True:
            there, step = next((w, d) for w, d in adjacent[here] if w != came)
            length += step
            came, here = here, there
            if here in sinks or len(adjacent[here]) != 2:
                break
        assert length <= cap + 1e-6, (mesh.points[tip], length)
    if cap == 0.0:
        assert not tips


def test_a_long_dead_end_is_refused() -> None:
    mesh = _mesh(12, 6)
    sink = _vertex(mesh, (0, 3))
    spec = NetworkSpec(mesh, (sink,), dead_end=6.0)
    assert _refused(spec, _edges_of(mesh, (0, 3), (9, 3)))  # a 9 m spur from the exit: fine
    assert not _refused(spec, _edges_of(mesh, (0, 3), (3, 3)))
    branch = _edges_of(mesh, (0, 3), (3, 3), (3, 0))
    assert not _refused(spec, branch)


def test_travel_stays_within_the_cap() -> None:
    """The middle of every active edge within `max_distance` of the exit along the
    network, walked here; a network walking farther is refused, one within accepted."""
    mesh = _mesh(18, 12)
    sinks = [_vertex(mesh, (0, 6))]
    capped = NetworkSpec(mesh, tuple(sinks), coverage=4.3, max_distance=18.0)
    edges = _solve(capped)
    walk = _walk(mesh, edges, sinks)
    for x in edges:  # the cap holds at the middle of every corridor edge
        i, j = mesh.edges[x]
        middle = min(walk[i], walk[j]) + math.dist(mesh.points[i], mesh.points[j]) / 2
        assert middle <= 18.0 + 1e-6, (mesh.points[i], mesh.points[j], middle)
    bare = NetworkSpec(mesh, tuple(sinks), max_distance=18.0)
    within = _edges_of(mesh, (0, 6), (15, 6), (15, 9))  # 16.5 m to the last edge's middle
    assert not _refused(bare, within)
    assert _refused(bare, within + _edges_of(mesh, (15, 9), (12, 9)))  # 19.5 m


def test_t_junctions_and_close_edges_forbidden() -> None:
    mesh = _mesh(15, 15)
    sinks = [_vertex(mesh, (0, 6)), _vertex(mesh, (15, 9))]
    spec = NetworkSpec(
        mesh,
        tuple(sinks),
        coverage=3.0 + 1e-6,
        t_junctions=Feature.FORBID,
        too_close=Feature.FORBID,
    )
    edges = set(_solve(spec))
    incident = mesh.incident()
    for v, around in enumerate(incident):
        if len(around) == 4:
            assert sum(1 for x in around if x in edges) != 3, mesh.points[v]
    for a, b in mesh.opposite:
        assert not (a in edges and b in edges)


def test_stochastic_search_returns_a_valid_network() -> None:
    """The Sec. 5.4 baseline keeps to the same rules (checked here, not by its judge)."""
    mesh = _mesh(12, 9)
    sinks = [_vertex(mesh, (0, 3))]
    spec = NetworkSpec(mesh, tuple(sinks), coverage=3.0 + 1e-6)
    found = stochastic_search(spec, time_limit=3.0, seed=1)
    active = {v for x in found.edges for v in mesh.edges[x]}
    assert found.judgement.valid
    assert active <= _reached(mesh, found.edges, sinks)
    assert found.judgement.length < sum(mesh.lengths)


def test_face_coverage_and_joined_exits() -> None:
    """Every cell has a network edge on a side, and the two exits lie in one network
    (a walk here from one reaches the other)."""
    mesh = _mesh(15, 12)
    sinks = [_vertex(mesh, (0, 6)), _vertex(mesh, (15, 6))]
    spec = NetworkSpec(mesh, tuple(sinks), faces_covered=True, join_sinks=True, lambda_length=1.0)
    edges = set(_solve(spec))
    assert all(any(x in edges for x in sides) for sides in mesh.faces)
    assert sinks[1] in _reached(mesh, sorted(edges), sinks[:1])
    apart = _edges_of(mesh, (0, 6), (3, 6)) + _edges_of(mesh, (12, 6), (15, 6))
    joined_spec = NetworkSpec(mesh, tuple(sinks), join_sinks=True)
    assert _refused(joined_spec, apart)
    assert not _refused(NetworkSpec(mesh, tuple(sinks)), apart)


def test_point_to_point_pairs_are_joined_by_a_short_path() -> None:
    """Eq. 7-8: with a pair of vertices on opposite sides of the floor, the network
    holds a path between them of at most the mesh's fewest edges + 2 (a breadth-first
    walk over the returned edges here); the cheapest network without the pair has none,
    so the constraint is what put it there."""
    mesh = _mesh(15, 12)
    sink = _vertex(mesh, (0, 6))
    a, b = _vertex(mesh, (6, 0)), _vertex(mesh, (6, 12))
    base = dict(coverage=3.0 + 1e-6, lambda_length=1.0)

    def hops(edges: list[int]) -> int | None:
        adjacent = _adjacent(mesh, edges)
        seen, frontier, steps = {a}, [a], 0
        while frontier and b not in seen:
            frontier = [w for v in frontier for w, _ in adjacent.get(v, []) if w not in seen]
            seen.update(frontier)
            steps += 1
        return steps if b in seen else None

    free = _solve(NetworkSpec(mesh, (sink,), **base))
    joined = _solve(NetworkSpec(mesh, (sink,), point_pairs=((a, b),), **base))
    assert hops(joined) is not None and hops(joined) <= 4 + 2
    assert hops(free) is None or hops(free) > 4 + 2


def _between(mesh: Mesh, edges: list[int], a: int, b: int) -> float:
    """The shortest walk from a to b over `edges` (Bellman-Ford from a)."""
    return _walk(mesh, edges, [a]).get(b, math.inf)


def test_a_route_walk_limit_counts_only_paths_within_it() -> None:
    """Eq. 7-8 with a walk limit (`pair_lengths`): a network joining the pair only by a
    21 m detour (7 edges, within the fewest 5 + 2) holds the pair by edges alone but is
    refused under a 15 m limit, by SCIP and by the judge alike; solved under the limit,
    the network's own walk between the pair is within it; a limit below every path is
    an error."""
    from floorplan.solver.network.stochastic import judge_spec

    mesh = _mesh(15, 12)
    sink = _vertex(mesh, (0, 6))
    a, b = _vertex(mesh, (3, 3)), _vertex(mesh, (12, 9))
    detour = _edges_of(
        mesh, (0, 6), (3, 6), (6, 6), (6, 3), (3, 3)
    ) + _edges_of(mesh, (3, 6), (3, 9), (12, 9))
    assert _between(mesh, detour, a, b) == pytest.approx(21.0)
    by_hops = NetworkSpec(mesh, (sink,), point_pairs=((a, b),))
    limited = NetworkSpec(mesh, (sink,), point_pairs=((a, b),), pair_lengths=(15.0,))
    assert judge_spec(by_hops, detour).valid and not _refused(by_hops, detour)
    assert not judge_spec(limited, detour).valid and _refused(limited, detour)
    covered = NetworkSpec(mesh, (sink,), coverage=3.0 + 1e-6, point_pairs=((a, b),),
                          pair_lengths=(15.0,))
    assert _between(mesh, _solve(covered), a, b) <= 15.0 + 1e-6
    with pytest.raises(ValueError, match="no path"):
        build_network(NetworkSpec(mesh, (sink,), point_pairs=((a, b),), pair_lengths=(14.0,)))
