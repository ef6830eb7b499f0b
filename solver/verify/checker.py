"""Verify every constraint of a problem on the final room shapes, independently of the MIQP.

The verdicts feed `Report.constraints` (DESIGN.md §2). Nothing here reads solver variables:
each check works on the rectangles a room ended up with, so a wrong formulation shows up
as a failed check instead of being repeated.

Coordinates a solver returns are only feasible within its own tolerance (SCIP: 1e-6), so
two rooms meant to share a wall may sit 1e-7 m apart, and exact shapely predicates would
then see no contact at all. Before the relational checks (inside, connected, overlap,
boundary, adjacency, coverage) the room coordinates closer than `tol` to each other, or to
a wall or obstacle of the domain, are therefore snapped onto one line. Measurements
(size, aspect ratio, size error, position) use the rectangles as given.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from floorplan.models import Adjacency, ConstraintCheck, Problem, Room
from floorplan.solver.families import FAMILIES
from floorplan.solver.geometry import (
    GRID,
    Box,
    GeometryError,
    boundary_edges,
    compass_words,
    contact_length,
    domain_lines,
    edges_named,
    room_polygon,
    shared_wall_length,
    snap_rooms,
)
from floorplan.solver.soft import (
    adjacency_soft,
    contact_shortfall,
    edge_shortfall,
    point_shortfall,
    ratio_shortfall,
    room_soft,
    size_shortfall,
)

#: Coverage at or above this share of the free area counts as covered (a soft goal).
COVERAGE_GOAL = 0.99
#: Kinds that do not decide `valid`: coverage is an objective term (Eq. 3), not a constraint.
SOFT_KINDS = frozenset({"coverage", "aisle_access"})


@dataclass(frozen=True)
class CheckResult:
    """Every verdict on a layout, plus the coverage and size-error measurements."""

    constraints: list[ConstraintCheck]
    coverage: float
    uncovered_area: float
    size_error: dict[str, float]
    valid: bool


@dataclass(frozen=True)
class PlacedRoom:
    """A room's rectangles as given (`shape`) and snapped to the shared lines (`snapped`)."""

    rects: tuple[Box, ...]
    snapped_rects: tuple[Box, ...]
    shape: BaseGeometry
    snapped: BaseGeometry

    @property
    def size(self) -> tuple[float, float]:
        """Width and depth of the bounding box, the room's (w_i, d_i) in the paper."""
        x0, y0, x1, y1 = self.shape.bounds
        return x1 - x0, y1 - y0


Placed = Mapping[str, PlacedRoom]


#: Metres within which the checker counts coordinates as equal, by default.
DEFAULT_TOL = 1e-4


def check_layout(
    problem: Problem, rooms: Mapping[str, Sequence[Box]], *, tol: float = DEFAULT_TOL,
    aisles: Sequence[BaseGeometry] = (),
) -> CheckResult:
    """Check every constraint of `problem` on `rooms` (room id -> its rectangles).
    `aisles` (large layouts) count as covered floor; `check_aisles` checks them."""
    placed = place_rooms(problem, rooms, tol)
    free = problem.free_area()
    cover, coverage, uncovered = check_coverage(free, placed, aisles)
    checks = [
        *check_placed(problem, rooms),
        *check_inside(problem, free, placed, tol),
        *check_connected(problem, placed, tol),
        # The other families of `solver.families`, in its order.
        *(c for kind in _AFTER_INSIDE for c in FAMILY_CHECKS[kind](problem, placed, tol)),
        cover,
    ]
    return CheckResult(
        constraints=checks,
        coverage=coverage,
        uncovered_area=uncovered,
        size_error=size_error(problem, placed),
        valid=all(c.satisfied or c.soft for c in checks if c.kind not in SOFT_KINDS),
    )


# Preparing the shapes.


def place_rooms(problem: Problem, rooms: Mapping[str, Sequence[Box]], tol: float) -> Placed:
    """The problem's rooms that have at least one rectangle, with snapped copies."""
    given = {r.id: tuple(rooms.get(r.id, ())) for r in problem.rooms}
    given = {room_id: rects for room_id, rects in given.items() if rects}
    xs, ys = domain_lines(problem)
    snapped = snap_rooms(given, xs, ys, tol)
    return {
        room_id: PlacedRoom(rects, tuple(snapped[room_id]), _union(rects),
                            _union(snapped[room_id]))
        for room_id, rects in given.items()
    }


def _union(rects: Sequence[Box]) -> BaseGeometry:
    # set_precision: union_all leaves a lone rectangle off the grid, and walls 1e-16 apart
    # then share no length.
    return shapely.set_precision(
        shapely.union_all([b.to_polygon() for b in rects], grid_size=GRID), GRID
    )


def _per_room(
    problem: Problem,
    placed: Placed,
    kind: str,
    wanted: Callable[[Room], bool],
    verdict: Callable[[Room, PlacedRoom], tuple[bool, str]],
) -> list[ConstraintCheck]:
    """One check per room that has the constraint; a room not placed fails it."""
    checks = []
    for room in problem.rooms:
        if not wanted(room):
            continue
        if room.id in placed:
            ok, detail = verdict(room, placed[room.id])
        else:
            ok, detail = False, "room not placed"
        checks.append(ConstraintCheck(kind=kind, rooms=[room.id], satisfied=ok, detail=detail))
    return checks


def _always(_: Room) -> bool:
    return True


# One function per constraint family.


def check_placed(problem: Problem, rooms: Mapping[str, Sequence[Box]]) -> list[ConstraintCheck]:
    """Every room of the problem has rectangles, and no unknown room has any."""
    known = {r.id for r in problem.rooms}
    missing = [ConstraintCheck(kind="placed", rooms=[r.id], satisfied=False,
                               detail="room has no rectangles")
               for r in problem.rooms if not rooms.get(r.id)]
    unknown = [ConstraintCheck(kind="placed", rooms=[room_id], satisfied=False,
                               detail="not a room of the problem")
               for room_id in rooms if room_id not in known]
    return missing + unknown


def check_inside(
    problem: Problem, free: BaseGeometry, placed: Placed, tol: float
) -> list[ConstraintCheck]:
    """C_inside (Eq. 1, with obstacles): each room lies within the outline minus obstacles."""

    def verdict(_: Room, p: PlacedRoom) -> tuple[bool, str]:
        outside = p.snapped.difference(free).area
        # Snapping already absorbed offsets below tol; what is left is a real protrusion.
        if outside <= tol * tol:
            return True, "inside the free area"
        return False, f"{outside:.2f} m² outside the free area"

    return _per_room(problem, placed, "inside", _always, verdict)


def check_connected(problem: Problem, placed: Placed, tol: float) -> list[ConstraintCheck]:
    """Each room's rectangles merge into one polygon (corner contact does not join them)."""

    def verdict(_: Room, p: PlacedRoom) -> tuple[bool, str]:
        try:
            polygon = room_polygon(p.snapped_rects)
        except GeometryError as err:
            return False, str(err)
        if polygon.area <= tol * tol:
            return False, "room has no area"
        return True, f"one polygon of {len(p.rects)} rectangle(s)"

    return _per_room(problem, placed, "connected", _always, verdict)


def check_overlap(problem: Problem, placed: Placed, tol: float) -> list[ConstraintCheck]:
    """C_overlap (Eq. 2): no two rooms' interiors overlap; one check per overlapping pair."""
    ids = [r.id for r in problem.rooms if r.id in placed]
    shapes = [placed[i].snapped for i in ids]
    # The tree keeps this near-linear for hundreds of rooms instead of testing every pair.
    # (It refuses an empty list, and a single room has no pair anyway.)
    pairs = shapely.STRtree(shapes).query(shapes, "intersects") if len(shapes) > 1 else [[], []]
    checks = []
    for i, j in zip(*map(list, pairs), strict=True):
        if i >= j:
            continue
        area = shapes[i].intersection(shapes[j]).area
        if area > tol:
            checks.append(ConstraintCheck(kind="overlap", rooms=[ids[i], ids[j]],
                                          satisfied=False, detail=f"overlap {area:.2f} m²"))
    if not checks:
        checks.append(ConstraintCheck(kind="overlap", rooms=ids, satisfied=True,
                                      detail="no two rooms overlap"))
    return checks


def check_size(problem: Problem, placed: Placed, tol: float) -> list[ConstraintCheck]:
    """C_size (Eq. 5): the bounding box's width and depth lie within min_size..max_size."""

    checks = []
    for room in problem.rooms:
        if room.min_size is None and room.max_size is None:
            continue
        soft = room_soft(problem, room)
        lo = room.min_size or (0.0, 0.0)
        hi = room.max_size or (float("inf"), float("inf"))
        bounds = [b for b, given in (("min_size", room.min_size), ("max_size", room.max_size))
                  if given is not None]
        if room.id not in placed:
            checks.append(ConstraintCheck(kind="size", rooms=[room.id], satisfied=False,
                                          detail="room not placed",
                                          soft=all(b in soft for b in bounds)))
            continue
        size = placed[room.id].size
        ok = all(lo[k] - tol <= size[k] <= hi[k] + tol for k in (0, 1))
        below = size_shortfall(size, room.min_size, None)
        above = size_shortfall(size, None, room.max_size)
        # Soft only if what is broken is soft: a hard bound broken is a hard failure.
        broken = [b for b, miss in (("min_size", below), ("max_size", above)) if miss > tol]
        checks.append(ConstraintCheck(
            kind="size", rooms=[room.id], satisfied=ok,
            detail=f"{_dims(size)} (needs {_dims(lo)} to {_dims(hi)})",
            soft=all(b in soft for b in (broken if not ok else bounds)),
            shortfall=0.0 if ok else _round(below + above)))
    return checks


def check_aspect_ratio(problem: Problem, placed: Placed, tol: float) -> list[ConstraintCheck]:
    """C_ratio (Eq. 7): long side / short side of the bounding box within [lo, hi]."""

    def verdict(room: Room, p: PlacedRoom) -> tuple[bool, str]:
        assert room.aspect_ratio is not None
        lo, hi = room.aspect_ratio
        long, short = max(p.size), min(p.size)
        # Eq. 7's linear form, so a degenerate room (short side 0) needs no division.
        ok = lo * short - tol <= long <= hi * short + tol
        ratio = long / short if short > 0 else float("inf")
        return ok, f"ratio {ratio:.2f} (needs {lo:.2f} to {hi:.2f})"

    checks = _per_room(problem, placed, "aspect_ratio",
                       lambda r: r.aspect_ratio is not None, verdict)
    rooms = [r for r in problem.rooms if r.aspect_ratio is not None]
    return [_soft_verdict(c, "aspect_ratio" in room_soft(problem, room),
                          lambda room=room: ratio_shortfall(placed[room.id].size,
                                                            room.aspect_ratio))
            for c, room in zip(checks, rooms, strict=True)]


def _soft_verdict(check: ConstraintCheck, soft: bool,
                  shortfall: Callable[[], float]) -> ConstraintCheck:
    """`check` marked soft or not, with its shortfall when it failed on a placed room."""
    update: dict[str, object] = {"soft": soft}
    if not check.satisfied and check.detail != "room not placed":
        update["shortfall"] = _round(shortfall())
    return check.model_copy(update=update)


def _round(value: float) -> float:
    """Shortfalls to the micrometre: SCIP's own tolerance is coarser."""
    return round(value, 6)


def check_position(problem: Problem, placed: Placed, tol: float) -> list[ConstraintCheck]:
    """C_pos (Eq. 8): the room covers each of its guide points."""
    checks = []
    for room in problem.rooms:
        soft = "positions" in room_soft(problem, room)
        for x, y in room.positions:
            shortfall = 0.0
            if room.id not in placed:
                ok, detail = False, "room not placed"
            else:
                gap = placed[room.id].shape.distance(Point(x, y))
                ok = gap <= tol
                detail = (f"covers ({x:.2f}, {y:.2f})" if ok
                          else f"misses ({x:.2f}, {y:.2f}) by {gap:.2f} m")
                if not ok:
                    shortfall = _round(point_shortfall(placed[room.id].rects, (x, y)))
            checks.append(ConstraintCheck(kind="position", rooms=[room.id], satisfied=ok,
                                          detail=detail, soft=soft, shortfall=shortfall))
    return checks


def check_boundary(problem: Problem, placed: Placed, tol: float) -> list[ConstraintCheck]:
    """C_boundary (Eq. 9): the room's outline runs along one of its named exterior edges."""
    edges = boundary_edges(problem.boundary)

    def verdict(room: Room, p: PlacedRoom) -> tuple[bool, str]:
        named = edges_named(problem, edges, room.boundary)
        contact = {e.index: p.snapped.boundary.intersection(LineString([e.start, e.end])).length
                   for e in named}
        best = max(contact, key=contact.__getitem__)
        edge = f"edge {best} ({'/'.join(sorted(compass_words(edges[best], problem.north)))})"
        if contact[best] > tol:
            return True, f"{contact[best]:.2f} m along {edge}"
        return False, f"touches none of edges {', '.join(map(str, contact))}"

    checks = _per_room(problem, placed, "boundary", lambda r: bool(r.boundary), verdict)
    rooms = [r for r in problem.rooms if r.boundary]
    return [_soft_verdict(c, "boundary" in room_soft(problem, room),
                          lambda room=room: edge_shortfall(
                              placed[room.id].snapped_rects,
                              edges_named(problem, edges, room.boundary)))
            for c, room in zip(checks, rooms, strict=True)]


def check_adjacency(problem: Problem, placed: Placed, tol: float) -> list[ConstraintCheck]:
    """C_adj (Eq. 10, Eq. 11 generalised): room a shares a wall of at least min_contact
    with b, or with the best of any_of."""
    checks = []
    for adj in problem.adjacency:
        check = _adjacency(adj, placed, tol)
        present = [placed[b].snapped_rects for b in adj.partners if b in placed]
        if adj.a in placed and present and adj.a not in adj.partners:
            check = _soft_verdict(check, adjacency_soft(problem, adj),
                                  lambda adj=adj, present=present: contact_shortfall(
                                      placed[adj.a].snapped_rects, present, adj.min_contact))
        else:
            check = check.model_copy(update={"soft": adjacency_soft(problem, adj)})
        checks.append(check)
    return checks


def _adjacency(adj: Adjacency, placed: Placed, tol: float) -> ConstraintCheck:
    """The verdict on one adjacency requirement."""
    partners = adj.partners
    rooms = [adj.a, *partners]
    needs = f"(needs {adj.min_contact:.2f})"
    if adj.a in partners:
        return ConstraintCheck(kind="adjacency", rooms=rooms, satisfied=False,
                               detail=f"'{adj.a}' cannot be adjacent to itself")
    if adj.a not in placed:
        return ConstraintCheck(kind="adjacency", rooms=rooms, satisfied=False,
                               detail=f"'{adj.a}' not placed")
    a = placed[adj.a].snapped
    # One straight stretch, as Eq. 10 makes it and a door needs: an L wrapping its
    # partner's corner shares two short walls whose sum would pass.
    contact = {b: contact_length(a, placed[b].snapped) for b in partners if b in placed}
    if not contact:
        return ConstraintCheck(kind="adjacency", rooms=rooms, satisfied=False,
                               detail="no partner placed")
    best = max(contact, key=contact.__getitem__)
    # With min_contact 0 the rooms must still touch, which a zero length alone cannot show.
    ok = contact[best] >= adj.min_contact - tol and a.distance(placed[best].snapped) <= tol
    detail = f"contact {contact[best]:.2f} m {needs}"
    if adj.any_of is not None:
        detail = f"best contact {contact[best]:.2f} m with '{best}' {needs}"
    return ConstraintCheck(kind="adjacency", rooms=rooms, satisfied=ok, detail=detail)


def check_coverage(
    free: BaseGeometry, placed: Placed, aisles: Sequence[BaseGeometry] = ()
) -> tuple[ConstraintCheck, float, float]:
    """The share of the free area the rooms (and aisles, part of the plan) cover (the
    goal behind E_cover, Eq. 3)."""
    shapes = [p.snapped for p in placed.values()] + list(aisles)
    covered = shapely.union_all(shapes).intersection(free).area
    total = free.area
    coverage = min(1.0, covered / total) if total > 0 else 1.0
    uncovered = max(0.0, total - covered)
    check = ConstraintCheck(kind="coverage", rooms=list(placed),
                            satisfied=coverage >= COVERAGE_GOAL,
                            detail=f"coverage {100 * coverage:.1f} %, "
                                   f"{uncovered:.2f} m² uncovered")
    return check, coverage, uncovered


def size_error(problem: Problem, placed: Placed) -> dict[str, float]:
    """E_size (Eq. 6) per placed room with a target: (W-W*)^2 + (D-D*)^2 of its bounding box."""
    errors = {}
    for room in problem.rooms:
        if room.target_size is not None and room.id in placed:
            (w, d), (tw, td) = placed[room.id].size, room.target_size
            errors[room.id] = (w - tw) ** 2 + (d - td) ** 2
    return errors


def _dims(size: Sequence[float]) -> str:
    return " x ".join("any" if v == float("inf") else f"{v:.2f}" for v in size)


# Aisles of large layouts (regions, Sec. 5.3): circulation floor, not rooms.


def check_aisles(
    problem: Problem, rooms: Mapping[str, BaseGeometry], aisles: Mapping[str, BaseGeometry],
    regions: Mapping[str, Sequence[str]], *, tol: float = 1e-4,
) -> list[ConstraintCheck]:
    """Kind `aisle`: the aisles overlap no room, lie inside the free area, form one
    connected network, reach the entrance (without one: the facade, the building's
    exits), and every region's rooms share at least a door's width of wall with them.
    Adjacencies naming two regions (kind `adjacency`): the regions face each other across
    an aisle (their rooms within an aisle's width, over `min_contact`) or share a wall."""
    names = list(aisles)
    network = shapely.union_all([aisles[a] for a in names]) if names else Point(0, 0).buffer(0)
    room_union = shapely.union_all(list(rooms.values())) if rooms else Point(0, 0).buffer(0)
    free = problem.free_area()
    checks = []
    overlap = float(network.intersection(room_union).area)
    checks.append(ConstraintCheck(kind="aisle", rooms=names, satisfied=overlap <= tol,
                                  detail=f"aisles overlap rooms by {overlap:.2f} m²"))
    outside = float(network.difference(free).area)
    checks.append(ConstraintCheck(kind="aisle", rooms=names, satisfied=outside <= tol,
                                  detail=f"{outside:.2f} m² of aisle outside the free area"))
    # Aisles meeting along a wall (not at a corner) are one corridor.
    joined = shapely.union_all([shapely.buffer(aisles[a], tol, join_style="mitre")
                                for a in names]) if names else network
    parts = len(getattr(joined, "geoms", [joined])) if names else 0
    checks.append(ConstraintCheck(kind="aisle", rooms=names, satisfied=parts == 1,
                                  detail=f"aisles form {parts} connected network(s)"))
    if problem.entrance is not None:
        gap = float(network.distance(Point(problem.entrance))) if names else float("inf")
        checks.append(ConstraintCheck(kind="aisle", rooms=names, satisfied=gap <= 1e-3,
                                      detail=f"aisles {gap:.2f} m from the entrance"))
    else:
        facade = float(network.boundary.intersection(problem.outline().exterior).length) \
            if names else 0.0
        checks.append(ConstraintCheck(kind="aisle", rooms=names,
                                      satisfied=facade >= problem.openings.door_width - tol,
                                      detail=f"aisles meet the facade over {facade:.2f} m"))
    door = problem.openings.door_width
    for region_id, members in regions.items():
        # A room left without floor (an empty polygon) has no wall to share.
        shapes = [rooms[r] for r in members if r in rooms and not rooms[r].is_empty]
        if not shapes:
            continue
        wall = shared_wall_length(shapely.union_all(shapes), network) if names else 0.0
        checks.append(ConstraintCheck(kind="aisle", rooms=[region_id, *members],
                                      satisfied=wall >= door - tol,
                                      detail=f"region '{region_id}' has {wall:.2f} m of wall "
                                             f"on an aisle (needs {door:.2f})"))
    region_ids = set(regions)
    for adj in problem.adjacency:
        if adj.a not in region_ids:
            continue
        checks.append(_region_adjacency(problem, adj, rooms, regions, tol))
    return checks


def _region_adjacency(problem: Problem, adj: Adjacency, rooms: Mapping[str, BaseGeometry],
                      regions: Mapping[str, Sequence[str]], tol: float) -> ConstraintCheck:
    """Two regions face each other when one, grown by an aisle's width, runs along the
    other over at least `min_contact`."""
    def shape(region_id: str) -> BaseGeometry:
        return shapely.union_all([rooms[r] for r in regions.get(region_id, []) if r in rooms])

    a = shape(adj.a)
    grown = shapely.buffer(a, problem.aisle_width + tol, join_style="mitre")
    facing = {b: float(grown.intersection(shape(b).boundary).length)
              for b in adj.partners if not shape(b).is_empty}
    best = max(facing, key=facing.__getitem__, default=None)
    length = facing.get(best, 0.0) if best is not None else 0.0
    return ConstraintCheck(kind="adjacency", rooms=[adj.a, *adj.partners],
                           satisfied=best is not None and length >= adj.min_contact - tol,
                           detail=f"regions face each other over {length:.2f} m "
                                  f"(needs {adj.min_contact:.2f})")


#: The check of each constraint family (`solver.families`, by its `check` kind) that
#: needs only the placed rooms; C_inside's also needs the free floor.
FAMILY_CHECKS: dict[str, Callable[[Problem, Placed, float], list[ConstraintCheck]]] = {
    "overlap": check_overlap, "size": check_size, "aspect_ratio": check_aspect_ratio,
    "position": check_position, "boundary": check_boundary, "adjacency": check_adjacency,
}
#: Report kinds of the families checked after C_inside, in the registry's order.
_AFTER_INSIDE = [f.check for f in FAMILIES if f.check is not None and f.check != "inside"]
