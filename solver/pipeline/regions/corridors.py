"""Corridors from what they must do (`Problem.corridors`; Peng et al., SIGGRAPH 2016,
Sec. 5.2): a corridor network planned by the network IP (`solver.network`) on a grid of
the floor, made into corridor polygons of the asked width and carved out of the floor;
the blocks left are the parts the rooms are laid out in by the large-layout pipeline
(`run.py`, in place of its band aisles), each block cut into strips one cell deep along
its corridors. Then the plan is measured (`corridor_rooms.py`): travel from each door to
the nearest exit along the corridors, dead ends, corridor area.

The grid's pitch is a room's depth plus half a corridor, so that a block between two
corridors a cell apart holds two rows of rooms, each on a corridor. Coverage is by cells
(every cell has a network edge on a side: `face_coverage`), two corridors one cell apart
are refused (Eq. 12, "too close"), so inner blocks are two rows deep; the exits are joined
into one network (`joined_sinks`), so that every exit is reachable from every door.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from floorplan.models import Corridors, Problem, Room
from floorplan.models.corridors import EXIT_TOLERANCE
from floorplan.solver.network import (
    Feature,
    Mesh,
    NetworkSpec,
    NetworkStatus,
    grid_mesh,
    solve_network,
)
from floorplan.solver.network.measure import dead_ends, distances
from floorplan.solver.network.mesh import cell_polygon, without
from floorplan.solver.network.solve import NetworkResult
from floorplan.solver.openings import CORNER_CLEARANCE
from floorplan.solver.pipeline.regions.aisles import (
    NARROWEST_PART,
    SLIVER_AREA,
    AisleNetwork,
    aisle_pieces,
    clean_shape,
)
from floorplan.solver.pipeline.regions.corridor_feedback import (
    Widening,
    forbidden_edges,
    least_side,
    too_thin,
    widening,
)
from floorplan.solver.pipeline.regions.corridor_strips import (
    CORNER_MARGIN,
    CornerRoom,
    _contact,
    _strips,
)
from floorplan.solver.pipeline.regions.partition import room_area, typical_area
from floorplan.solver.pipeline.regions.parts import polygon_pieces

#: Share of the time limit the network may take, and at most this many seconds.
NETWORK_SHARE = 0.35
NETWORK_SECONDS = 20.0
#: The grid's pitch stays within these (metres): finer grids grow the IP fast.
MIN_PITCH, MAX_PITCH = 2.5, 8.0


@dataclass(frozen=True)
class CorridorPlan:
    """The planned network and what the rooms get: blocks by id and the corridors as
    the aisle network the large-layout pipeline lays rooms out around."""

    mesh: Mesh
    sinks: tuple[int, ...]
    result: NetworkResult
    shape: BaseGeometry
    blocks: dict[str, Polygon]
    network: AisleNetwork
    #: The deepest a strip's row of rooms is planned (the larger cell side less half a
    #: corridor).
    depth: float = math.inf
    #: Strips of one room (a floor's corner, `_corner_strip`), by their WKB.
    singles: frozenset[bytes] = frozenset()
    #: The grid changed after a first network left a strip no room fits
    #: (`corridor_feedback`), else empty.
    widened: Widening = field(default_factory=Widening)
    _axes: dict[bytes, tuple[int, float]] = field(default_factory=dict, repr=False,
                                                  compare=False)

    def most(self, part: Polygon) -> int | None:
        """The most rooms `part` may be dealt: one for a corner's strip, else any."""
        return 1 if part.wkb in self.singles else None

    def capacity(self, part: Polygon) -> float:
        """The floor a strip gives its rooms when dealt them: its area, but no deeper
        than `depth` along its length. Dealt by area, mall-140's west column (5.4 m
        deep, 29.8 m long) got 12 rooms, too many for one row along its corridor."""
        x0, y0, x1, y1 = part.bounds
        length = max(x1 - x0, y1 - y0, 1e-9)
        return min(float(part.area), length * self.depth)

    def fit(self, part: Polygon, room: Room) -> float:
        """How badly `room`'s target suits a strip, in E_size's terms (Eq. 6): the square
        of its target side across the strip (depth along a row on a corridor running
        along x, width along a column on one running along y) less the strip's depth,
        which a row of rooms laid along its corridor takes. Dealt by area alone, rooms
        3.5 m deep went to 2.76 m rows beside 3.13 m ones (bench/NOTES.md,
        "Corridors")."""
        if room.target_size is None:
            return 0.0
        axis, depth = self._across(part)
        return (depth - room.target_size[axis]) ** 2

    def _across(self, part: Polygon) -> tuple[int, float]:
        """The axis across `part` (1: y, a row on a corridor along x; 0: x) and its
        extent along it."""
        key = part.wkb
        if key not in self._axes:
            along_x, along_y = _contact(part, self.shape.buffer(1e-4, join_style="mitre"))
            x0, y0, x1, y1 = part.bounds
            self._axes[key] = (1, y1 - y0) if along_x >= along_y else (0, x1 - x0)
        return self._axes[key]


#: Grids tried around the rooms' pitch for one that lets every cell reach an exit.
MESH_TRIES = 60
#: The share of the floor the corridors are expected to take when the rooms' sizes are
#: scaled to what is left (`room_pitch`).
EXPECTED_SHARE = 0.22


def room_depth(problem: Problem) -> float:
    """The depth a row of rooms is planned at: the median of the rooms' longer target
    side (else the side of a square of a room's area). Used by the bench's square grids;
    the product plans with `room_pitch`."""
    typical = typical_area(problem)
    sides = [
        max(r.target_size) if r.target_size else math.sqrt(room_area(r, typical))
        for r in problem.rooms
    ]
    return statistics.median(sides)


def room_pitch(problem: Problem, width: float) -> tuple[float, float]:
    """The grid's cell size along x and y: the rooms' median target width (x) and depth
    (y), scaled by how much the rooms must shrink to fit the floor less the corridors,
    plus half a corridor. A row of rooms along a corridor running along x is then as
    deep as its rooms' (scaled) depth, a row along a corridor running along y as deep
    as their width, so the rooms keep their proportions whichever way the IP runs a
    corridor; a square grid from the longer side made office-154's rooms a metre deeper
    than asked and far narrower (E_size median 2.1-2.5; bench/NOTES.md, "Corridors")."""
    typical = typical_area(problem)
    sizes = [
        r.target_size if r.target_size else (math.sqrt(room_area(r, typical)),) * 2
        for r in problem.rooms
    ]
    asked = sum(w * d for w, d in sizes)
    room = float(problem.free_area().area) * (1 - EXPECTED_SHARE)
    scale = min(1.0, math.sqrt(room / asked)) if asked > 0 else 1.0
    px = scale * statistics.median(w for w, _ in sizes) + width / 2
    py = scale * statistics.median(d for _, d in sizes) + width / 2
    return (min(MAX_PITCH, max(MIN_PITCH, px)), min(MAX_PITCH, max(MIN_PITCH, py)))


def grid_anchors(problem: Problem, corridors: Corridors) -> list[tuple[float, float]]:
    """The points the grid's lines run through: the exits first (the lines run from the
    first one inside the floor), then, for each obstacle an exit lies on (a stair or lift
    core), its two sides across the exit's side (`_core_sides`)."""
    return [*corridors.exits, *(p for pair, _ in _core_sides(problem, corridors) for p in pair)]


def spread_axes(problem: Problem, corridors: Corridors) -> tuple[bool, bool]:
    """Per axis (x, y), whether the grid's lines are spread evenly between the anchors'
    lines (`grid_mesh`'s `spread`): on both axes once an exit lies on a core. Run from
    one exit at the pitch, office-72-core's lines left 6.6 and 3.0 m columns at its ends
    (rows 5.7 and 2.1 m deep for rooms 4 m wide); spread only along the axis of the
    core's sides, office-60-two-cores got no network and office-96-l lost a door;
    spread on mall-140 (exits on the outline only), no network in the time
    (bench/NOTES.md, "Corridors")."""
    cored = bool(_core_sides(problem, corridors))
    return (cored, cored)


def _core_sides(
    problem: Problem, corridors: Corridors
) -> list[tuple[tuple[tuple[float, float], tuple[float, float]], int]]:
    """For each obstacle an exit lies on, two points on its sides across the exit's side
    and the axis they fix: for an exit on its west or east side, x = west and x = east
    at the exit's y (axis 0). Without them a core cut cells so that two beside it kept
    two sides each, each facing an active edge across its neighbour (too close), and no
    network was found (office-72-core). All four sides made the cells beside an exit on
    a core's middle 2 m deep, the rows there 1.1 m (E_size median 1.16-1.20); the sides
    of every obstacle (mall-140's atria and stairs too) cost mall-140 8-11 rooms' doors
    (bench/NOTES.md, "Corridors")."""
    out: list[tuple[tuple[tuple[float, float], tuple[float, float]], int]] = []
    for obstacle in problem.obstacles:
        box = obstacle.to_box()
        x0, y0, x1, y1 = box.bounds
        for e in corridors.exits:
            if box.exterior.distance(Point(e)) > EXIT_TOLERANCE:
                continue
            if min(abs(e[0] - x0), abs(e[0] - x1)) <= EXIT_TOLERANCE:
                out.append((((x0, e[1]), (x1, e[1])), 0))
            if min(abs(e[1] - y0), abs(e[1] - y1)) <= EXIT_TOLERANCE:
                out.append((((e[0], y0), (e[0], y1)), 1))
    return out


def walkable_pitch(
    problem: Problem, corridors: Corridors, pitch: tuple[float, float]
) -> tuple[tuple[float, float], float]:
    """The pitch (and thinnest outer cell, in pitches) nearest `pitch` whose grid gives
    every cell a side within walking reach of an exit: the middle of one of its sides
    no farther from an exit than the travel cap, walked along x and y (a lower bound on
    any walk along grid corridors). On mall-140 (exits mid-south and mid-north, 45 m)
    the cells at the middle of the east and west walls had none at the rooms' pitch, and
    the IP was infeasible; a slightly finer x pitch with a wider outer column serves
    them (bench/NOTES.md, "Corridors"). `pitch` itself when no nearby grid does."""
    if corridors.max_travel is None:
        return pitch, 0.5
    cap = corridors.max_travel - corridors.width / 2
    free = problem.free_area()
    steps = (1.0, 0.97, 1.03, 0.94, 1.06, 0.91, 1.09, 0.88, 1.12)
    tries = sorted(
        ((sx, sy, thin) for sx in steps for sy in steps for thin in (0.5, 0.75)),
        key=lambda t: (abs(t[0] - 1) + abs(t[1] - 1), t[2]),
    )
    for sx, sy, thin in tries[:MESH_TRIES]:
        trial = (pitch[0] * sx, pitch[1] * sy)
        mesh = grid_mesh(free, trial, anchors=grid_anchors(problem, corridors), thinnest=thin,
                         spread=spread_axes(problem, corridors))
        if _walkable(mesh, corridors.exits, cap):
            return trial, thin
    return pitch, 0.5


def _walkable(mesh: Mesh, exits: Sequence[tuple[float, float]], cap: float) -> bool:
    middles = [
        ((mesh.points[i][0] + mesh.points[j][0]) / 2, (mesh.points[i][1] + mesh.points[j][1]) / 2)
        for i, j in mesh.edges
    ]
    near = [
        min(abs(m[0] - e[0]) + abs(m[1] - e[1]) for e in exits) <= cap + 1e-9 for m in middles
    ]
    return all(any(near[x] for x in sides) for sides in mesh.faces)


def network_spec(
    problem: Problem,
    corridors: Corridors,
    pitch: float | tuple[float, float],
    thinnest: float = 0.5,
    widened: Widening | None = None,
) -> NetworkSpec:
    """The IP for this floor: exits as sinks joined into one network, every cell along
    the network (a room in it opens onto a corridor), no corridors a cell
    apart, the travel cap less half a corridor (a door is on the corridor's side), the
    dead-end cap less half a corridor (the corridor runs on past its last vertex), each
    route as a pair of Eq. 7-8 between the grid vertices nearest its points, its walk
    limit less the straight legs from the points to them.
    The cells in the floor's outer corners need no corridor on a side of their own
    (`_floor_corner`). `widened`: the grid lines moved and the edges forbidden after
    a first network left a strip no room fits (`corridor_feedback`)."""
    free = problem.free_area()
    mesh = grid_mesh(free, pitch, anchors=grid_anchors(problem, corridors), thinnest=thinnest,
                     spread=spread_axes(problem, corridors),
                     moved=widened.moved if widened else ((), ()))
    if widened:
        mesh = without(mesh, forbidden_edges(mesh, widened.forbid))
    kept = [k for k, f in enumerate(mesh.faces)
            if not _floor_corner(mesh, f, free) and not _cut_by_obstacle(mesh, k, free)]
    mesh = replace(mesh, faces=[mesh.faces[k] for k in kept],
                   cells=[mesh.cells[k] for k in kept] if mesh.cells else [])
    sinks = tuple(dict.fromkeys(mesh.nearest(e) for e in corridors.exits))
    half = corridors.width / 2
    pairs, limits = [], []
    for route in corridors.routes:
        ends = [_route_vertex(mesh, p) for p in route.between]
        pairs.append((ends[0], ends[1]))
        # The walk from each point to its grid vertex comes off the limit.
        legs = sum(math.dist(p, mesh.points[v]) for p, v in zip(route.between, ends, strict=True))
        limits.append(None if route.max_walk is None else route.max_walk - legs)
    return NetworkSpec(
        mesh,
        sinks,
        coverage=None,
        faces_covered=True,
        join_sinks=True,
        max_distance=None if corridors.max_travel is None else corridors.max_travel - half,
        dead_end=None if corridors.dead_ends is None else max(0.0, corridors.dead_ends - half),
        too_close=Feature.FORBID,
        lambda_length=corridors.weights.length,
        # Per mesh edge: equal weights then trade a metre of corridor against a metre of
        # mean walk, whatever the floor's size.
        lambda_distance=corridors.weights.travel / max(1, len(mesh.edges)),
        point_pairs=tuple(pairs),
        pair_lengths=tuple(limits),
    )


def _route_vertex(mesh: Mesh, point: tuple[float, float]) -> int:
    """The grid vertex a route's point is planned from: the nearest inside the floor
    (two or more edges), as a corridor ending on the outline is a dead end; on a 30 x
    12 m floor a route snapped to outline vertices could only be a pair of 6 m stubs
    over the dead-end cap, and the IP was infeasible."""
    incident = mesh.incident()
    inner = [v for v in range(len(mesh.points)) if len(incident[v]) >= 2]
    if not inner:
        return mesh.nearest(point)
    return min(inner, key=lambda v: math.dist(mesh.points[v], point))


def _floor_corner(mesh: Mesh, sides: Sequence[int], free: BaseGeometry) -> bool:
    """Whether the cell of `sides` sits in a corner of the floor's outline: two of its
    sides are mesh edges meeting inside the floor, the other two lie along the outline
    (not an obstacle). Covering such a cell took a corridor stub to the wall on each of
    office-154's four corners (a dead end, 32 m2, 1.6 % of the floor); without one the
    cell's piece and the end of a strip beside it make the place of one room with a
    door past the corridor's end (`_corner_strip`; bench/NOTES.md, "Corridors")."""
    if len(sides) != 2:
        return False
    (a, b), (c, d) = (mesh.edges[x] for x in sides)
    inner = {a, b} & {c, d}
    if len(inner) != 1:
        return False
    v = inner.pop()
    p, q, o = mesh.points[a + b - v], mesh.points[c + d - v], mesh.points[v]
    corner = (p[0] + q[0] - o[0], p[1] + q[1] - o[1])
    if not isinstance(free, Polygon):
        return False
    wall = free.exterior
    return all(
        wall.distance(LineString([corner, end])) <= 1e-6 for end in (p, q)
    )


#: A cell an obstacle leaves less than this share of needs no corridor of its own.
CUT_CELL_SHARE = 0.6


def _cut_by_obstacle(mesh: Mesh, face: int, free: BaseGeometry) -> bool:
    """Whether an obstacle (a core) takes more than 1 - `CUT_CELL_SHARE` of the cell of
    `face`: what is left (a strip thinner than a room beside the core) need not lie on a
    corridor; covering it forced a corridor along the core's far side, too close to the
    next one, and no network was found (office-72-core). Its piece joins a strip
    beside it (`_strips`)."""
    if not mesh.cells:
        return False
    box = shapely.box(*mesh.cells[face])
    inside = free.intersection(box).area
    return inside < CUT_CELL_SHARE * box.area and not free.covers(box)


def _corner_points(free: BaseGeometry) -> list[tuple[float, float]]:
    """The convex corners of the free floor's outline: where a cell may have two sides
    along the outline and no corridor of its own (`_floor_corner`)."""
    if not isinstance(free, Polygon):
        return []
    ring = list(orient(free, 1.0).exterior.coords)[:-1]
    out = []
    for k, (x, y) in enumerate(ring):
        (ax, ay), (bx, by) = ring[k - 1], ring[(k + 1) % len(ring)]
        if (x - ax) * (by - y) - (y - ay) * (bx - x) > 1e-9:
            out.append((float(x), float(y)))
    return out


def plan_corridors(
    problem: Problem, time_limit: float, seed: int = 0, late: bool = False
) -> CorridorPlan | None:
    """The corridor network of the floor and the blocks it leaves, or None when the IP
    found no network in its time (or proved there is none). With `late` (the limit is
    our default, not the user's: a late layout rather than none, bench/NOTES.md, "A busy
    machine"), a network SCIP stopped without gets a second try. Where the network leaves a
    strip no room fits (shallower than every room's least side), a second network on a
    grid widened there (`corridor_feedback`) in half the time, kept when it leaves less
    such floor."""
    corridors = problem.corridors
    assert corridors is not None
    pitch, thinnest = walkable_pitch(problem, corridors, room_pitch(problem, corridors.width))
    spec = network_spec(problem, corridors, pitch, thinnest)
    seconds = min(NETWORK_SECONDS, time_limit * NETWORK_SHARE)
    patience = min(NETWORK_SECONDS, 2 * seconds) if late else 0.0
    plan = _plan(problem, spec, seconds, seed, patience=patience)
    least = least_side(problem)
    if plan is None or least is None:
        return plan
    thin = _thin(plan, least)
    if not thin:
        return plan
    anchors = grid_anchors(problem, corridors)
    widened = widening(plan.mesh, plan.result.edges, plan.sinks,
                       [(s, plan._across(s)[0]) for s in thin], corridors.width,
                       ([a[0] for a in anchors], [a[1] for a in anchors]), pitch)
    if not widened:
        return plan
    second = _plan(problem, network_spec(problem, corridors, pitch, thinnest, widened),
                   seconds / 2, seed)
    if second is None:
        return plan
    left = sum(s.area for s in _thin(second, least))
    return replace(second, widened=widened) if left < sum(s.area for s in thin) else plan


def _thin(plan: CorridorPlan, least: float) -> list[Polygon]:
    """The plan's strips (not a corner's one-room strips) no room fits."""
    strips = [s for s in plan.blocks.values() if s.wkb not in plan.singles]
    return too_thin(strips, plan._across, least)


def _plan(
    problem: Problem, spec: NetworkSpec, seconds: float, seed: int, patience: float = 0.0
) -> CorridorPlan | None:
    """The network of `spec` made into corridors and the strips between (None: no
    network in `seconds`, nor in `patience` seconds more when SCIP stopped without
    one rather than proving there is none: on a 60-room floor under load the start's
    repair needed 3.3 s of the 2.6 s its half of 5.25 s gave it, and a floor without
    corridors is worth the rooms' time; bench/NOTES.md, "Corridors")."""
    corridors = problem.corridors
    assert corridors is not None
    try:
        result = solve_network(spec, time_limit=seconds, seed=seed)
        if result.status == NetworkStatus.NO_SOLUTION and patience > 0:
            result = solve_network(spec, time_limit=patience, seed=seed)
    except ValueError:  # a route no grid path of its length joins (Eq. 7-8)
        return None
    if not result.found:
        return None
    free = problem.free_area()
    least = least_side(problem)
    shape = clean_shape(cell_polygon(spec.mesh, result.edges, corridors.width, free))
    blocks: dict[str, Polygon] = {}
    narrow: list[BaseGeometry] = []
    singles: list[Polygon] = []
    half = corridors.width / 2
    corner = CornerRoom(problem.openings.door_width + 2 * CORNER_CLEARANCE + CORNER_MARGIN,
                        (spec.mesh.pitch[0] - half, spec.mesh.pitch[1] - half),
                        tuple(_corner_points(free)))
    for piece in polygon_pieces(clean_shape(free.difference(shape))):
        if piece.area <= SLIVER_AREA:
            continue
        if piece.buffer(-NARROWEST_PART / 2 + 1e-6, join_style="mitre").is_empty:
            narrow.append(piece)  # too thin for a room: corridor floor
        elif least is not None and _one_row(piece, least):
            # One row between its corridors, not two strips of half a row each
            # (bench/NOTES.md, "Corridors").
            blocks[f"block-{len(blocks) + 1}"] = piece
        else:
            strips, floor = _strips(piece, spec.mesh, shape, NARROWEST_PART,
                                    corner=corner, singles=singles)
            narrow += floor
            for strip in strips:
                blocks[f"block-{len(blocks) + 1}"] = strip
    shape = clean_shape(shapely.union_all([shape, *narrow]))
    pieces = aisle_pieces([shape], free, blocks)
    network = AisleNetwork(pieces, {b: [p] for b, p in blocks.items()})
    depth = max(spec.mesh.pitch) - corridors.width / 2
    return CorridorPlan(spec.mesh, spec.sinks, result, shape, blocks, network, depth,
                        frozenset(p.wkb for p in singles))


def _one_row(piece: Polygon, least: float) -> bool:
    """Whether `piece` is a rectangle less than two rooms' least sides deep: a block
    between two corridors too shallow for two rows."""
    x0, y0, x1, y1 = piece.bounds
    return piece.area >= (x1 - x0) * (y1 - y0) - 1e-6 and min(x1 - x0, y1 - y0) < 2 * least


def planned_dead_ends(plan: CorridorPlan, width: float) -> list[float]:
    """Dead ends of the planned network, metres, the corridor's run past its last
    vertex (half its width) included."""
    return sorted(
        (d + width / 2 for d in dead_ends(plan.mesh, plan.result.edges, plan.sinks)), reverse=True
    )


def planned_travel(plan: CorridorPlan) -> float:
    """The longest walk along the planned network from a vertex to an exit."""
    reached = distances(plan.mesh, plan.result.edges, plan.sinks)
    return max(reached.values(), default=0.0)
