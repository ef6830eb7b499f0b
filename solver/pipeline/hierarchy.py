"""The hierarchical framework (paper Sec. 5.3): select sub-domains, split their rooms
into halves, update the constraints, re-solve each sub-domain.

A layout in progress is a list of `Piece`s, the rectangles of the rooms. Under
C_refine every half covers its share of the parent and can only grow, so what held
at the previous level (positions, boundary contact, adjacency, minimum sizes) keeps
holding; the sub-problem only has to bound growth (room envelopes) and keep the two
halves of each split together. The last step, the gaps left absorbed by the rooms
around them, is solver/pipeline/absorb.py's.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from floorplan.models import Problem
from floorplan.solver.geometry import EPS, Box, Domain, Edge, bounding_box, on_edge, rectangles_of
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec, Refine, Split
from floorplan.solver.soft import room_soft

#: Uncovered parts smaller than this (m²) are numerical dust, not gaps.
GAP_AREA = 1e-3
#: A split never makes a half thinner than this (metres); a thinner room is split the other way.
MIN_HALF = 0.25
#: Rooms one sub-domain may hold: a larger MIQP would not solve in its time share.
MAX_SUBDOMAIN_ROOMS = 12
#: Pieces per room at most; beyond it a room's rectangles are no longer split.
MAX_PIECES_PER_ROOM = 16


@dataclass(frozen=True)
class Piece:
    """One rectangle of a room, with the guide points and edges it answers for."""

    name: str
    room: str
    box: Box
    positions: tuple[tuple[float, float], ...] = ()
    edges: tuple[Edge, ...] = ()
    #: The room's soft constraint families, inherited by the halves of a split.
    soft: frozenset[str] = frozenset()


@dataclass(frozen=True)
class SubDomain:
    """Rooms to refine together (paper Sec. 5.3), with the gaps beside them."""

    rooms: frozenset[str]


def uncovered_gaps(domain: Domain, pieces: Sequence[Piece]) -> list[Polygon]:
    """The parts of the free area no room covers, each a polygon."""
    return domain.gaps((p.box for p in pieces), GAP_AREA)


def touching(a: BaseGeometry, b: BaseGeometry) -> bool:
    """Sharing a stretch of boundary, not only a corner."""
    return a.distance(b) <= EPS and a.buffer(EPS).intersection(b).length > 10 * EPS


def as_pieces(rooms: dict[str, list[Box]]) -> list[Piece]:
    """A layout given as room id -> rectangles, as pieces answering for nothing alone."""
    return [Piece(f"{room_id}#{k}", room_id, b)
            for room_id, boxes in rooms.items() for k, b in enumerate(boxes)]


def room_boxes(pieces: Iterable[Piece]) -> dict[str, list[Box]]:
    rooms: dict[str, list[Box]] = {}
    for p in pieces:
        rooms.setdefault(p.room, []).append(p.box)
    return rooms


def relative_size_error(problem: Problem, rooms: dict[str, list[Box]]) -> dict[str, float]:
    """E_size (Eq. 6) of each room's bounding box over |target|², for rooms with a target."""
    errors = {}
    for room in problem.rooms:
        if room.target_size is None or room.id not in rooms:
            continue
        b = bounding_box(rooms[room.id])
        tw, td = room.target_size
        errors[room.id] = ((b.width - tw) ** 2 + (b.depth - td) ** 2) / max(tw * tw + td * td, EPS)
    return errors


def select_subdomains(
    problem: Problem, domain: Domain, pieces: Sequence[Piece]
) -> list[SubDomain]:
    """Sec. 5.3: the rooms around each uncovered region; and a room whose size error
    exceeds the threshold with its neighbours. Only rooms below their target are
    taken, as refinement can only grow rooms. Overlapping selections are merged up to
    `MAX_SUBDOMAIN_ROOMS`; beyond, they are solved one after the other."""
    rooms = room_boxes(pieces)
    shapes = {r: shapely.union_all([b.to_polygon() for b in boxes]) for r, boxes in rooms.items()}
    groups: list[set[str]] = []
    for gap in uncovered_gaps(domain, pieces):
        around = {r for r, shape in shapes.items() if touching(shape, gap)}
        if around:
            groups.append(around)
    threshold = problem.options.size_error_threshold
    for room_id, error in relative_size_error(problem, rooms).items():
        room = problem.room(room_id)
        b = bounding_box(rooms[room_id])
        assert room.target_size is not None
        too_small = b.width < room.target_size[0] - EPS or b.depth < room.target_size[1] - EPS
        if error > threshold and too_small:
            near = {r for r, shape in shapes.items() if touching(shape, shapes[room_id])}
            groups.append({room_id} | near)
    return _merge_groups(groups)


def _merge_groups(groups: list[set[str]]) -> list[SubDomain]:
    merged: list[set[str]] = []
    for rooms in groups:
        rooms = set(rooms)
        keep = []
        for other in merged:
            if other & rooms and len(other | rooms) <= MAX_SUBDOMAIN_ROOMS:
                rooms |= other
            else:
                keep.append(other)
        merged = [*keep, rooms]
    return [SubDomain(frozenset(r)) for r in merged]


def split_piece(piece: Piece, direction: Split) -> tuple[Piece, Piece]:
    """Two halves of equal size (Fig. 6); a guide point goes to the half containing it,
    an edge to the first half lying on it."""
    b = piece.box
    if direction == "vertical":
        mid = (b.x0 + b.x1) / 2
        halves = (Box(b.x0, b.y0, mid, b.y1), Box(mid, b.y0, b.x1, b.y1))
    else:
        mid = (b.y0 + b.y1) / 2
        halves = (Box(b.x0, b.y0, b.x1, mid), Box(b.x0, mid, b.x1, b.y1))
    points = [tuple(p for p in piece.positions if (h.contains_point(*p))) for h in halves]
    points[1] = tuple(p for p in points[1] if p not in points[0])
    if "positions" in piece.soft:
        # A soft point the room misses goes on with the nearer half, which may grow
        # toward it.
        for p in piece.positions:
            if p not in points[0] and p not in points[1]:
                k = _nearer(halves, p)
                points[k] = (*points[k], p)
    # An edge goes to one half lying on it; the other keeps touching it anyway, as
    # the halves cover the parent. An edge neither half lies on is dropped: the room's
    # C_boundary is already met through another of its candidate edges (or, soft and
    # missed, goes on with the nearer half).
    edges: list[list[Edge]] = [[], []]
    for e in piece.edges:
        for k in (0, 1):
            if on_edge(halves[k], e):
                edges[k].append(e)
                break
        else:
            if "boundary" in piece.soft:
                edges[_nearer(halves, ((e.start[0] + e.end[0]) / 2,
                                       (e.start[1] + e.end[1]) / 2))].append(e)
    return tuple(  # type: ignore[return-value]
        Piece(f"{piece.name}.{k}", piece.room, halves[k], points[k], tuple(edges[k]),
              piece.soft)
        for k in range(2)
    )


def _nearer(halves: tuple[Box, Box], point: tuple[float, float]) -> int:
    """The index of the half nearer to `point`."""
    x, y = point
    far = [max(h.x0 - x, x - h.x1, h.y0 - y, y - h.y1, 0.0) for h in halves]
    return 0 if far[0] <= far[1] else 1


def choose_split(piece: Piece, rng: random.Random) -> Split:
    """A random direction (Sec. 5.3), unless it would make a half too thin."""
    direction: Split = rng.choice(("vertical", "horizontal"))
    along = piece.box.width if direction == "vertical" else piece.box.depth
    if along / 2 < MIN_HALF:
        direction = "horizontal" if direction == "vertical" else "vertical"
    return direction


@dataclass(frozen=True)
class RefinementPlan:
    """A sub-domain's MIQP and the halves it starts from (a feasible warm start)."""

    spec: LevelSpec
    start: dict[str, Box]
    pieces: dict[str, Piece]


def plan_refinement(
    problem: Problem,
    domain: Domain,
    pieces: Sequence[Piece],
    sub: SubDomain,
    *,
    level: int,
    index: int,
    rng: random.Random,
) -> RefinementPlan:
    """Initialise the sub-domain by room decomposition and update the constraints."""
    inside = [p for p in pieces if p.room in sub.rooms]
    # Gaps are found afresh: an earlier sub-domain of this level may have filled some.
    around = shapely.union_all([p.box.to_polygon() for p in inside])
    gaps = [g for g in uncovered_gaps(domain, pieces) if touching(around, g)]
    region_shape = shapely.union_all([p.box.to_polygon() for p in inside] + gaps)
    region = Box(*region_shape.bounds)
    blocked = tuple(rectangles_of(region.to_polygon().difference(region_shape)))
    delta = max([max(g.bounds[2] - g.bounds[0], g.bounds[3] - g.bounds[1]) for g in gaps],
                default=0.0)
    delta = max(delta, 0.5)
    rects, contacts, start, children = _halves(inside, delta, rng)
    envelopes = _envelopes(problem, domain, sub, inside, children)
    spec = LevelSpec(
        name=f"{problem.name}/level{level}/sub{index}",
        region=region,
        blocked=blocked,
        free_area=float(region_shape.area),
        rects=tuple(rects),
        contacts=tuple(contacts),
        envelopes=tuple(envelopes),
        cover_weight=problem.weights.cover,
        size_weight=max(problem.weights.size, problem.weights.cover / 2),
        violation_weight=problem.weights.violation,
    )
    return RefinementPlan(spec, start, children)


def _halves(
    inside: Sequence[Piece], delta: float, rng: random.Random,
) -> tuple[list[RectSpec], list[ContactSpec], dict[str, Box], dict[str, Piece]]:
    """Each piece of a sub-domain split in two (Sec. 5.3), or kept whole when its room
    has pieces enough: the halves' specs (C_refine against their parent), the contacts
    that keep two halves together, their start and which piece each name is."""
    per_room: dict[str, int] = {}
    for p in inside:
        per_room[p.room] = per_room.get(p.room, 0) + 1
    rects: list[RectSpec] = []
    contacts: list[ContactSpec] = []
    start: dict[str, Box] = {}
    children: dict[str, Piece] = {}
    for p in inside:
        if per_room[p.room] * 2 > MAX_PIECES_PER_ROOM:
            halves: tuple[Piece, ...] = (p,)
            direction: Split = "vertical"
        else:
            direction = choose_split(p, rng)
            halves = split_piece(p, direction)
        for k, h in enumerate(halves):
            rects.append(RectSpec(
                name=h.name,
                room=h.room,
                min_size=_min_half(h.box, direction, len(halves)),
                target=(h.box.width, h.box.depth),
                positions=h.positions,
                edges=h.edges,
                refine=Refine(parent=p.box, direction=direction,
                              child=k if len(halves) == 2 else -1, delta=delta),
                soft=h.soft & {"positions", "boundary"},
            ))
            start[h.name] = h.box
            children[h.name] = h
        if len(halves) == 2:
            side = p.box.depth if direction == "vertical" else p.box.width
            contacts.append(ContactSpec(
                name=f"halves[{p.name}]",
                a=(halves[0].name,),
                partners=((halves[1].name,),),
                min_contact=side * 0.999,  # they share the whole split line
            ))
    return rects, contacts, start, children


def _envelopes(problem: Problem, domain: Domain, sub: SubDomain, inside: Sequence[Piece],
               children: dict[str, Piece]) -> list[EnvelopeSpec]:
    """Per room of the sub-domain, the envelope of its halves: its size and ratio on the
    bounding box, relaxed where the previous level had to exceed them."""
    envelopes = []
    for room_id in sorted(sub.rooms):
        names = tuple(n for n, h in children.items() if h.room == room_id)
        previous = bounding_box([p.box for p in inside if p.room == room_id])
        max_size, ratio = relaxed_bounds(problem, room_id, previous,
                                         (domain.bbox.width, domain.bbox.depth))
        envelopes.append(EnvelopeSpec(room_id, names, previous, max_size, ratio))
    return envelopes


def relaxed_bounds(
    problem: Problem, room_id: str, now: Box, unbounded: tuple[float, float],
) -> tuple[tuple[float, float], tuple[float, float] | None]:
    """The maximum size and aspect ratio a room may grow within. A soft bound the room
    already breaks is moved to where the room is: growth may not make the violation
    worse, and the room need not shrink (refinement only grows rooms)."""
    room = problem.room(room_id)
    soft = room_soft(problem, room)
    max_size = room.max_size or unbounded
    if "max_size" in soft:
        max_size = (max(max_size[0], now.width), max(max_size[1], now.depth))
    ratio = room.aspect_ratio
    if ratio is not None and "aspect_ratio" in soft:
        long, short = max(now.width, now.depth), min(now.width, now.depth)
        actual = long / max(short, EPS)
        ratio = (min(ratio[0], actual), max(ratio[1], actual))
    return max_size, ratio


def _min_half(b: Box, direction: Split, n: int) -> tuple[float, float]:
    """Halves keep a usable thickness across the split line."""
    if n == 1:
        return (b.width, b.depth)
    if direction == "vertical":
        return (min(MIN_HALF, b.width), b.depth)
    return (b.width, min(MIN_HALF, b.depth))


def apply_refinement(
    pieces: Sequence[Piece], plan: RefinementPlan, boxes: dict[str, Box]
) -> list[Piece]:
    """Replace the sub-domain's pieces with the solved halves, merging halves that
    still form one rectangle so rooms do not fragment needlessly."""
    rooms = {h.room for h in plan.pieces.values()}
    kept = [p for p in pieces if p.room not in rooms]
    solved = [replace(h, box=_snap(boxes[name])) for name, h in plan.pieces.items()]
    return kept + merge_rectangular_pairs(solved)


def _snap(b: Box, grid: float = 1e-6) -> Box:
    return Box(*(round(v / grid) * grid for v in (b.x0, b.y0, b.x1, b.y1)))


def merge_rectangular_pairs(pieces: list[Piece]) -> list[Piece]:
    """Merge two pieces of one room whose union is exactly a rectangle."""
    by_room: dict[str, list[Piece]] = {}
    for p in pieces:
        by_room.setdefault(p.room, []).append(p)
    return [merged for group in by_room.values() for merged in _merge_room(group)]


def _merge_room(pieces: list[Piece]) -> list[Piece]:
    result = list(pieces)
    merged = True
    while merged:
        merged = False
        for i, j in itertools.combinations(range(len(result)), 2):
            a, b = result[i], result[j]
            joined = _rect_union(a.box, b.box)
            if joined is not None:
                result[i] = Piece(a.name, a.room, joined, a.positions + b.positions,
                                  a.edges + tuple(e for e in b.edges if e not in a.edges))
                del result[j]
                merged = True
                break
    return result


def _rect_union(a: Box, b: Box, tol: float = 1e-6) -> Box | None:
    same_x = abs(a.x0 - b.x0) <= tol and abs(a.x1 - b.x1) <= tol
    same_y = abs(a.y0 - b.y0) <= tol and abs(a.y1 - b.y1) <= tol
    if same_x and (abs(a.y1 - b.y0) <= tol or abs(b.y1 - a.y0) <= tol):
        return Box(a.x0, min(a.y0, b.y0), a.x1, max(a.y1, b.y1))
    if same_y and (abs(a.x1 - b.x0) <= tol or abs(b.x1 - a.x0) <= tol):
        return Box(min(a.x0, b.x0), a.y0, max(a.x1, b.x1), a.y1)
    return None
