"""The network IP of Peng et al. (SIGGRAPH 2016, Sec. 4) on SCIP.

A subset of the mesh's edges is chosen as the network. One function per constraint family,
named after it and citing the paper's equation; `build_network` adds them in the paper's
order. Variables (paper symbols):

- ``E[x]``: edge x active; ``H[(i, j)]``: half-edge i->j active (E_{i->j});
- ``D[(i, j)]``: distance value of half-edge i->j (D_{i->j}), falling towards a sink;
- ``L[(i, j, k)]``: half-edge i->j hands over to j->k (L_{i->j; j->k});
- ``V[v]``: vertex v active (V_y); ``T``/``Z``: T-junction and too-close indicators;
- ``F[(i, j)]``: flow on half-edge i->j joining the sinks.

Extensions of ours, each in its own function: a cap on the walk to a sink from the middle
of every active edge (`travel_cap`, from the distance values), a cap on dead-end length
(`dead_end_cap`, generalising Eq. 9-10 from "no dead end" to "none longer than the cap"),
coverage of the mesh's cells (`face_coverage`) and the sinks joined into one network
(`joined_sinks`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import StrEnum

from pyscipopt import Model, Variable, quicksum

from floorplan.solver.network.mesh import Mesh


class Feature(StrEnum):
    """How a local feature (T-junction, edges too close) is treated (Sec. 4.2, L2)."""

    ALLOW = "allow"
    PENALISE = "penalise"
    FORBID = "forbid"


@dataclass(frozen=True)
class NetworkSpec:
    """What the network must do: sinks (exits), coverage range, caps, feature controls,
    and the objective's weights (Eq. 14)."""

    mesh: Mesh
    sinks: tuple[int, ...]
    #: Every vertex within this distance (metres) of an active vertex (Eq. 6); None: none.
    coverage: float | None = None
    #: Every cell of the mesh has an active edge on a side (`face_coverage`).
    faces_covered: bool = False
    #: The sinks are joined by the network (one network, every exit reachable from all).
    join_sinks: bool = False
    #: Vertices the network must pass (Sec. 4.2, L2 (v)).
    required: tuple[int, ...] = ()
    #: Every sink must be reached by the network (exits that are not used are no exits).
    sinks_required: bool = True
    #: The longest walk (metres) along the network from an active vertex to a sink.
    max_distance: float | None = None
    #: The longest dead end (metres); 0 forbids dead ends (Eq. 9-10); None: any.
    dead_end: float | None = None
    #: Point-to-point constraint (Eq. 7-8, Sec. 4.2 L1): vertex pairs (a, b) joined by
    #: at least one path of active edges with no more edges than the mesh's shortest
    #: path between them plus `path_slack`.
    point_pairs: tuple[tuple[int, int], ...] = ()
    path_slack: int = 2
    #: Per pair of `point_pairs` (when given), the longest such path in metres (None:
    #: any of them); paths longer are not counted (ours: a walk limit on Eq. 7-8).
    pair_lengths: tuple[float | None, ...] = ()
    t_junctions: Feature = Feature.ALLOW
    too_close: Feature = Feature.ALLOW
    lambda_length: float = 1.0
    lambda_distance: float = 0.0
    lambda_t: float = 0.0
    lambda_close: float = 0.0


@dataclass
class NetworkModel:
    """The SCIP model and its variables by key."""

    model: Model
    spec: NetworkSpec
    E: dict[int, Variable] = field(default_factory=dict)
    H: dict[tuple[int, int], Variable] = field(default_factory=dict)
    D: dict[tuple[int, int], Variable] = field(default_factory=dict)
    L: dict[tuple[int, int, int], Variable] = field(default_factory=dict)
    V: dict[int, Variable] = field(default_factory=dict)
    T: dict[tuple[int, int], Variable] = field(default_factory=dict)
    Z: dict[int, Variable] = field(default_factory=dict)
    F: dict[tuple[int, int], Variable] = field(default_factory=dict)
    P: dict[tuple[int, int, int], Variable] = field(default_factory=dict)
    paths: dict[tuple[int, int, int], list[int]] = field(default_factory=dict)
    distance_bound: float = 0.0


def half_edges(mesh: Mesh) -> Iterator[tuple[int, int, float]]:
    for (i, j), length in zip(mesh.edges, mesh.lengths, strict=True):
        yield i, j, length
        yield j, i, length


def build_network(spec: NetworkSpec) -> NetworkModel:
    """The whole IP (Eq. 14 subject to Eq. 1-13 and our caps)."""
    nm = NetworkModel(Model("network"), spec)
    edge_indicators(nm)
    travel_cap(nm)  # before Eq. 2, whose big-M follows the distances' bound
    no_island(nm)
    vertex_activity(nm)
    coverage(nm)
    face_coverage(nm)
    sinks(nm)
    joined_sinks(nm)
    required_nodes(nm)
    point_to_point(nm)
    dead_end_cap(nm)
    t_junctions(nm)
    too_close(nm)
    objective(nm)
    return nm


def edge_indicators(nm: NetworkModel) -> None:
    """Eq. 4: an edge is active iff at least one of its half-edges is:
    -1 <= E_{i->j} + E_{j->i} - 2 E_x <= 0. Distance values get their bound here: the
    sum of all half-edge lengths (Delta_all); `travel_cap` may tighten it."""
    m, mesh = nm.model, nm.spec.mesh
    nm.distance_bound = 2 * sum(mesh.lengths)
    for x, (i, j) in enumerate(mesh.edges):
        nm.E[x] = m.addVar(f"E_{x}", vtype="B")
        for a, b in ((i, j), (j, i)):
            nm.H[(a, b)] = m.addVar(f"H_{a}_{b}", vtype="B")
            nm.D[(a, b)] = m.addVar(f"D_{a}_{b}", lb=0.0, ub=nm.distance_bound)
        total = nm.H[(i, j)] + nm.H[(j, i)] - 2 * nm.E[x]
        m.addCons(total <= 0, f"eq4_hi_{x}")
        m.addCons(total >= -1, f"eq4_lo_{x}")
        # The same disaggregated: equivalent on integers, a much tighter relaxation.
        m.addCons(nm.H[(i, j)] <= nm.E[x], f"eq4_ij_{x}")
        m.addCons(nm.H[(j, i)] <= nm.E[x], f"eq4_ji_{x}")
        m.addCons(nm.E[x] <= nm.H[(i, j)] + nm.H[(j, i)], f"eq4_any_{x}")


def no_island(nm: NetworkModel) -> None:
    """Eq. 1-3 (Prop. 4.2): an active half-edge i->j into a non-sink j hands over to an
    active succeeding half-edge j->k (k != i) whose distance value is smaller by at least
    the length of i->j. Eq. 2's big-M is the distances' bound plus the length (the least
    valid one), not Delta_all."""
    m, mesh = nm.model, nm.spec.mesh
    sink_set = set(nm.spec.sinks)
    incident = mesh.incident()
    for i, j, length in half_edges(mesh):
        if j in sink_set:
            continue
        big_m = nm.distance_bound + length
        hand_over = []
        for x in incident[j]:
            k = mesh.other(x, j)
            if k == i:
                continue
            ell = m.addVar(f"L_{i}_{j}_{k}", vtype="B")
            nm.L[(i, j, k)] = ell
            hand_over.append(ell)
            m.addCons(ell <= nm.H[(j, k)], f"eq1_{i}_{j}_{k}")
            m.addCons(
                nm.D[(j, k)] - nm.D[(i, j)] + big_m * ell <= big_m - length, f"eq2_{i}_{j}_{k}"
            )
        m.addCons(nm.H[(i, j)] - quicksum(hand_over) <= 0, f"eq3_{i}_{j}")


def vertex_activity(nm: NetworkModel) -> None:
    """Eq. 5: a vertex is active iff one of its edges is:
    1 - |E_y| <= sum E_x - |E_y| V_y <= 0."""
    m, mesh = nm.model, nm.spec.mesh
    for v, edges in enumerate(mesh.incident()):
        nm.V[v] = m.addVar(f"V_{v}", vtype="B", ub=1.0 if edges else 0.0)
        if not edges:
            continue
        total = quicksum(nm.E[x] for x in edges) - len(edges) * nm.V[v]
        m.addCons(total <= 0, f"eq5_hi_{v}")
        m.addCons(total >= 1 - len(edges), f"eq5_lo_{v}")
        for x in edges:  # disaggregated, as for Eq. 4
            m.addCons(nm.E[x] <= nm.V[v], f"eq5_{v}_{x}")


def coverage(nm: NetworkModel) -> None:
    """Eq. 6: every vertex of the mesh is covered by an active vertex within the
    coverage range."""
    spec = nm.spec
    if spec.coverage is None:
        return
    points = spec.mesh.points
    for v, p in enumerate(points):
        near = [
            u
            for u, q in enumerate(points)
            if math.dist(p, q) <= spec.coverage + 1e-9 and nm.V[u].getUbOriginal() > 0
        ]
        nm.model.addCons(quicksum(nm.V[u] for u in near) >= 1, f"eq6_{v}")


def face_coverage(nm: NetworkModel) -> None:
    """A coverage model of ours for floors (the paper allows others, Sec. 4.1 C2): every
    cell has an active edge on one of its sides, so whatever fills a cell (a room) lies
    along the network: sum of E over the cell's sides >= 1."""
    if not nm.spec.faces_covered:
        return
    for k, sides in enumerate(nm.spec.mesh.faces):
        nm.model.addCons(quicksum(nm.E[x] for x in sides) >= 1, f"face_{k}")


def joined_sinks(nm: NetworkModel) -> None:
    """Ours, in the spirit of the point-to-point constraint (Eq. 7-8) at the cost of a
    flow: one unit leaves the first sink for each other sink over active edges only
    (f <= (S - 1) E on both half-edges), so every sink lies in one network; with
    Prop. 4.2 every active vertex reaches a sink, so the whole network is one piece and
    every exit can be reached from anywhere on it."""
    spec = nm.spec
    if not spec.join_sinks or len(spec.sinks) < 2:
        return
    m, mesh = nm.model, spec.mesh
    units = len(spec.sinks) - 1
    flow = nm.F
    for x, (i, j) in enumerate(mesh.edges):
        for a, b in ((i, j), (j, i)):
            flow[(a, b)] = m.addVar(f"F_{a}_{b}", lb=0.0, ub=units)
            m.addCons(flow[(a, b)] <= units * nm.E[x], f"flow_cap_{a}_{b}")
    source, targets = spec.sinks[0], set(spec.sinks[1:])
    for v, edges in enumerate(mesh.incident()):
        out = quicksum(flow[(v, mesh.other(x, v))] for x in edges)
        into = quicksum(flow[(mesh.other(x, v), v)] for x in edges)
        supply = units if v == source else (-1 if v in targets else 0)
        m.addCons(out - into == supply, f"flow_{v}")


def sinks(nm: NetworkModel) -> None:
    """Sinks (Sec. 3 (iv)): the exits are vertices the network must reach when
    `sinks_required`; Eq. 1-3 already exempt half-edges into them."""
    if not nm.spec.sinks_required:
        return
    for s in nm.spec.sinks:
        nm.model.addCons(nm.V[s] >= 1, f"sink_{s}")


def required_nodes(nm: NetworkModel) -> None:
    """User specifications (Sec. 4.2, L2 (v)): vertices the network must pass."""
    for v in nm.spec.required:
        nm.model.addCons(nm.V[v] >= 1, f"required_{v}")


#: Paths enumerated per point-to-point pair at most; a pair with more is refused (pairs
#: are meant to be near, as the paper's samples of adjacent sub-meshes are).
MAX_PATHS = 20000


def point_to_point(nm: NetworkModel) -> None:
    """Eq. 7-8 (Sec. 4.2, L1): for each pair (a, b), every simple path of the mesh from
    a to b with at most (fewest edges + `path_slack`) edges gets an indicator P, on only
    when all its N edges are: -N + 1 <= N P - sum E <= 0; and at least one P of the
    pair is on. Raises ValueError for a pair with more than `MAX_PATHS` such paths."""
    spec = nm.spec
    if not spec.point_pairs:
        return
    m = nm.model
    for (a, b), paths in zip(spec.point_pairs, pair_paths(spec), strict=True):
        if not paths:
            raise ValueError(f"point_pairs: no path joins vertices {a} and {b}")
        indicators = []
        for k, edges in enumerate(paths):
            p = m.addVar(f"P_{a}_{b}_{k}", vtype="B")
            nm.P[(a, b, k)] = p
            nm.paths[(a, b, k)] = edges
            indicators.append(p)
            total = len(edges) * p - quicksum(nm.E[x] for x in edges)
            m.addCons(total <= 0, f"eq7_hi_{a}_{b}_{k}")
            m.addCons(total >= 1 - len(edges), f"eq7_lo_{a}_{b}_{k}")
        m.addCons(quicksum(indicators) >= 1, f"eq8_{a}_{b}")


def pair_paths(spec: NetworkSpec) -> list[list[list[int]]]:
    """Per pair of `spec.point_pairs`, the edges of each path Eq. 7-8 counts: at most
    (fewest edges + `path_slack`) edges (`hop_paths`) and no longer than the pair's
    `pair_lengths`, shortest first."""
    mesh = spec.mesh
    incident = mesh.incident()
    lengths = mesh.lengths
    out = []
    for k, (a, b) in enumerate(spec.point_pairs):
        limit = spec.pair_lengths[k] if k < len(spec.pair_lengths) else None
        paths = [
            p for p in hop_paths(mesh, incident, a, b, spec.path_slack)
            if limit is None or sum(lengths[x] for x in p) <= limit + 1e-9
        ]
        out.append(sorted(paths, key=lambda p: sum(lengths[x] for x in p)))
    return out


def hop_paths(
    mesh: Mesh, incident: list[list[int]], a: int, b: int, slack: int
) -> Iterator[list[int]]:
    """The edges of each simple path from a to b with at most (fewest edges + slack)
    edges (depth-first, pruned by the fewest edges still needed to reach b)."""
    hops = {b: 0}
    frontier = [b]
    while frontier:
        nxt = []
        for v in frontier:
            for x in incident[v]:
                w = mesh.other(x, v)
                if w not in hops:
                    hops[w] = hops[v] + 1
                    nxt.append(w)
        frontier = nxt
    if a not in hops:
        return
    limit = hops[a] + slack
    count = 0
    stack: list[tuple[int, list[int], frozenset[int]]] = [(a, [], frozenset((a,)))]
    while stack:
        here, used, seen = stack.pop()
        if here == b:
            count += 1
            if count > MAX_PATHS:
                raise ValueError(f"point_pairs: more than {MAX_PATHS} paths join {a} and {b}")
            yield used
            continue
        for x in incident[here]:
            w = mesh.other(x, here)
            if w not in seen and len(used) + 1 + hops.get(w, limit + 1) <= limit:
                stack.append((w, [*used, x], seen | {w}))


def travel_cap(nm: NetworkModel) -> None:
    """Ours, from Eq. 2: along the hand-over chain from an active half-edge i->j the
    distance value falls by at least each half-edge's length, so the walk from j to the
    sink is at most D_{i->j} - Delta_{i->j} plus the last half-edge's length (at most
    the longest edge into a sink, `last_leg`). Bounding D_{i->j} by `max_distance` -
    longest + Delta_{i->j} / 2
    keeps the middle of every active edge within `max_distance` of a sink along the
    network (a vertex within that plus half an edge). A bound on the vertices instead
    refused edges whose two ends are both far (the last cell of a floor's far corner)."""
    spec = nm.spec
    if spec.max_distance is None:
        return
    longest = last_leg(spec)
    bounds = {}
    for i, j, length in half_edges(spec.mesh):
        bounds[(i, j)] = max(0.0, spec.max_distance - longest + length / 2)
        nm.model.chgVarUb(nm.D[(i, j)], min(nm.distance_bound, bounds[(i, j)]))
    nm.distance_bound = min(nm.distance_bound, max(bounds.values(), default=0.0))


def last_leg(spec: NetworkSpec) -> float:
    """The longest mesh edge at a sink: the last half-edge of every chain enters a sink
    (the longest edge of all was needlessly strict on grids with wider outer cells)."""
    sink_set = set(spec.sinks)
    at_sinks = [
        length
        for (i, j), length in zip(spec.mesh.edges, spec.mesh.lengths, strict=True)
        if i in sink_set or j in sink_set
    ]
    return max(at_sinks or spec.mesh.lengths or [0.0])


def dead_end_cap(nm: NetworkModel) -> None:
    """Ours, generalising Eq. 9-10: a dead end runs from a tip (an active non-sink vertex
    of one active edge) through vertices of two active edges to the first junction or
    sink, and none may be longer than the cap. For every simple path v0 .. v_k of the
    mesh that first gets longer than the cap at its last edge, with v0 .. v_{k-1} not
    sinks: if all its k edges are active, some other edge at v0 .. v_{k-1} is active too
    (sum of its edges - sum of those others <= k - 1). A cap below every edge's length is
    Eq. 9-10's "no dead ends"."""
    spec = nm.spec
    if spec.dead_end is None:
        return
    mesh = spec.mesh
    incident = mesh.incident()
    sink_set = set(spec.sinks)
    count = 0
    for start in range(len(mesh.points)):
        if start in sink_set or not incident[start]:
            continue
        for path, used in _paths(mesh, incident, start, spec.dead_end, sink_set):
            others = {x for v in path[:-1] for x in incident[v]} - set(used)
            nm.model.addCons(
                quicksum(nm.E[x] for x in used) - quicksum(nm.E[x] for x in others)
                <= len(used) - 1,
                f"dead_end_{count}",
            )
            count += 1


def _paths(
    mesh: Mesh, incident: list[list[int]], start: int, cap: float, sink_set: set[int]
) -> Iterator[tuple[list[int], list[int]]]:
    """Simple paths from `start` that first get longer than `cap` at their last edge,
    whose vertices before the last are not sinks: (vertices, edges)."""
    lengths = mesh.lengths
    stack: list[tuple[list[int], list[int], float]] = [([start], [], 0.0)]
    while stack:
        path, used, length = stack.pop()
        if length > cap + 1e-9:
            yield path, used
            continue
        here = path[-1]
        if len(path) > 1 and here in sink_set:
            continue
        for x in incident[here]:
            there = mesh.other(x, here)
            if there not in path:
                stack.append(([*path, there], [*used, x], length + lengths[x]))


def t_junctions(nm: NetworkModel) -> None:
    """Eq. 13: at a valence-4 vertex j, T_{x,j} = 1 when edge x is inactive and the three
    others active: 0 <= E_1 + E_2 + E_3 + (1 - E_0) - 4 T <= 3. Forbidden: T fixed at 0;
    penalised: weighted in the objective (only T's lower side then binds)."""
    spec = nm.spec
    if spec.t_junctions is Feature.ALLOW:
        return
    m = nm.model
    for j, edges in enumerate(spec.mesh.incident()):
        if len(edges) != 4:
            continue
        for x in edges:
            rest = quicksum(nm.E[y] for y in edges if y != x)
            t = m.addVar(
                f"T_{x}_{j}", vtype="B", ub=0.0 if spec.t_junctions is Feature.FORBID else 1.0
            )
            nm.T[(x, j)] = t
            m.addCons(rest + (1 - nm.E[x]) - 4 * t <= 3, f"eq13_{x}_{j}")


def too_close(nm: NetworkModel) -> None:
    """Eq. 12 (k = 1, "edges too close"): the two opposite edges of a cell both active:
    0 <= E_a + E_b - 2 Z <= 1. Forbidden: Z fixed at 0; penalised: weighted."""
    spec = nm.spec
    if spec.too_close is Feature.ALLOW:
        return
    m = nm.model
    for k, (a, b) in enumerate(spec.mesh.opposite):
        z = m.addVar(f"Z_{k}", vtype="B", ub=0.0 if spec.too_close is Feature.FORBID else 1.0)
        nm.Z[k] = z
        m.addCons(nm.E[a] + nm.E[b] - 2 * z <= 1, f"eq12_{k}")


def objective(nm: NetworkModel) -> None:
    """Eq. 14: lambda_L sum Delta_x E_x + lambda_D sum D_{i->j} + lambda_Z sum Z +
    lambda_T sum T."""
    spec = nm.spec
    lengths = spec.mesh.lengths
    terms = spec.lambda_length * quicksum(lengths[x] * e for x, e in nm.E.items())
    if spec.lambda_distance:
        terms += spec.lambda_distance * quicksum(nm.D.values())
    if nm.T and spec.lambda_t:
        terms += spec.lambda_t * quicksum(nm.T.values())
    if nm.Z and spec.lambda_close:
        terms += spec.lambda_close * quicksum(nm.Z.values())
    nm.model.setObjective(terms, "minimize")
