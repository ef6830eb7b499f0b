"""Level 1 of the hierarchy: one rectangle per room (paper Sec. 5.1-5.2), and the
size-window heuristic of Sec. 5.4 that makes SCIP find a first layout quickly."""

from __future__ import annotations

import math
from collections.abc import Mapping

import shapely
import shapely.prepared
from shapely.geometry import Polygon, box

from floorplan.models import Problem, Room
from floorplan.solver.geometry import Box, Domain, edges_named, on_edge
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec
from floorplan.solver.soft import adjacency_soft, room_soft

#: Sec. 5.4: with targets, start the size bounds at 90-110 % of the target ...
WINDOW_START = 0.10
#: ... and widen them by 10 % of the target at each failed attempt.
WINDOW_STEP = 0.10
#: When no window holds, the first layout under the user's own bounds keeps the rooms'
#: sides as near target +-50 % as it can (`target_bands`). Measured on a 15-room brief
#: whose hall must reach both side walls (no window holds), seeds 10-29, median Eq. 12
#: of the final layout: 66.3 without, 63.9 at 10 %, 50.4 at 20 %, 50.1 at 30 %, 46.4 at
#: 50 %, 47.4 at 70 % (bench/NOTES.md, "Ten runs against the flat model, a topology
#: step, and a free-shaped hall").
FIRST_BAND = 0.5
#: An extra rectangle of a room shares at least this much wall with its main one
#: (metres): wide enough to walk through, so the room stays one usable space ...
WING_JOIN = 1.2
#: ... and is at least this wide and deep (metres).
WING_MIN = 1.0
#: Rectangles a room may become when the brief leaves it open (`max_rects` unset): an
#: L takes two, a T, U or Z three: the shapes rooms take in real plans (docs/method.md,
#: "Rooms of several rectangles").
DEFAULT_MAX_RECTS = 3
#: Separates a room's id from the number of one of its extra rectangles.
WING_MARK = "~wing"
#: In the soft model every room keeps at least this width and depth (metres), or its
#: maximum when smaller: a room squeezed to nothing by its neighbours' demands is
#: not a plan, whatever its own constraints say.
SOFT_FLOOR = 0.5


def size_bounds(room: Room, domain: Domain, window: float | None) -> tuple[
    tuple[float, float], tuple[float, float]
]:
    """(min, max) [width, depth] of a room: the user's bounds (or 0 and the domain's
    box), narrowed to target * (1 -/+ window) when the room has a target and
    `window` is given. The window never leaves the user's bounds."""
    lo = list(room.min_size or (0.0, 0.0))
    hi = list(room.max_size or (domain.bbox.width, domain.bbox.depth))
    if room.target_size is not None and window is not None:
        for axis in range(2):
            t = room.target_size[axis]
            lo[axis] = min(max(lo[axis], t * (1 - window)), hi[axis])
            hi[axis] = max(min(hi[axis], t * (1 + window)), lo[axis])
    return (lo[0], lo[1]), (hi[0], hi[1])


def target_bands(problem: Problem, domain: Domain, window: float) -> dict[
    str, tuple[tuple[float, float], tuple[float, float]]
]:
    """(min, max) [width, depth] of target * (1 -/+ `window`) within the user's bounds,
    for the main rectangle of each room with a target: what `e_band_shortfall` pulls
    toward."""
    return {room.id: size_bounds(room, domain, window) for room in problem.rooms
            if room.target_size is not None}


def windows_to_try(problem: Problem) -> list[float | None]:
    """The relaxation schedule: 10 %, 20 %, ... until every target window has reached
    the user's bounds; `None` means the user's bounds themselves."""
    widest = 0.0
    for room in problem.rooms:
        if room.target_size is None:
            continue
        for axis in range(2):
            t = room.target_size[axis]
            if t <= 0:
                continue
            lo = room.min_size[axis] if room.min_size else 0.0
            hi = room.max_size[axis] if room.max_size else math.inf
            widest = max(widest, (t - lo) / t, (hi - t) / t if math.isfinite(hi) else 1.0)
    steps = []
    window = WINDOW_START
    while window < widest - 1e-9 and len(steps) < 10:
        steps.append(round(window, 6))
        window += WINDOW_STEP
    return [*steps, None]


def level_one_spec(
    problem: Problem, domain: Domain, *, window: float | None,
    wings: Mapping[str, int] | None = None, soft: bool = False, wrap: bool = True,
) -> LevelSpec:
    """Level 1: every room one rectangle, every constraint of the request; a room in
    `wings` gets that many more rectangles (docs/method.md, "Rooms of several
    rectangles"), each sharing at least `WING_JOIN` metres of wall with the room's main
    rectangle, which answers for the room's guide points, boundary and target, while its
    size maximum and aspect ratio hold on the bounding box of all of them (an exact
    envelope). With `soft`, the problem's soft constraints get slacks priced at
    `Weights.violation` per metre. With `wrap`, a room may wrap around an obstacle on
    the outline (`Notch`)."""
    wings = wings or {}
    rects = []
    contacts: list[ContactSpec] = []
    envelopes = []
    for room in problem.rooms:
        lo, hi = size_bounds(room, domain, window)
        extra = wing_names(room.id, wings.get(room.id, 0))
        relaxed = room_soft(problem, room) if soft else frozenset()
        rects.append(_main_rect(problem, domain, room, (lo, hi), bool(extra), relaxed, soft))
        for name in extra:
            rects.append(RectSpec(name=name, room=room.id, min_size=(WING_MIN, WING_MIN),
                                  max_size=hi, target=(WING_MIN, WING_MIN)))
            contacts.append(ContactSpec(name=f"join[{name}]", a=(name,),
                                        partners=((room.id,),), min_contact=WING_JOIN))
        if extra:
            envelopes.append(EnvelopeSpec(
                room.id, (room.id, *extra), None, hi, room.aspect_ratio,
                soft=frozenset(relaxed), min_size=lo,
                positions=() if "positions" in relaxed else tuple(room.positions)))

    def parts(room_id: str) -> tuple[str, ...]:
        return (room_id, *wing_names(room_id, wings.get(room_id, 0)))

    contacts += [
        ContactSpec(
            name=f"adj{k}",
            a=parts(adj.a),
            partners=tuple(parts(p) for p in adj.partners),
            min_contact=adj.min_contact,
            soft=soft and adjacency_soft(problem, adj),
        )
        for k, adj in enumerate(problem.adjacency)
    ]
    notches = domain.notches if wrap else ()
    wrapped = {n.obstacle for n in notches}
    return LevelSpec(
        name=f"{problem.name}/level1",
        region=domain.bbox,
        blocked=tuple(b for b in domain.blocked if b not in wrapped),
        notches=notches,
        free_area=domain.area,
        rects=tuple(rects),
        contacts=tuple(contacts),
        envelopes=tuple(envelopes),
        cover_weight=problem.weights.cover,
        size_weight=problem.weights.size,
        violation_weight=problem.weights.violation if soft else 0.0,
    )


def _main_rect(problem: Problem, domain: Domain, room: Room,
               bounds: tuple[tuple[float, float], tuple[float, float]], winged: bool,
               relaxed: frozenset[str], soft: bool) -> RectSpec:
    """A room's main level-1 rectangle, answering for its guide points, boundary and
    target; its minimum size and ratio hold on the envelope instead when it has wings."""
    lo, hi = bounds
    if winged:
        # The minimum holds on the bounding box (the envelope): the arm holding a
        # guide point may be narrower than the room, as in any L.
        lo = (min(lo[0], WING_MIN), min(lo[1], WING_MIN))
    return RectSpec(
        name=room.id,
        room=room.id,
        min_size=lo,
        max_size=hi,
        target=room.target_size,
        aspect_ratio=None if winged else room.aspect_ratio,
        # A winged room's guide points may lie in any of its rectangles (the envelope's),
        # unless they are soft.
        positions=tuple(room.positions) if not winged or "positions" in relaxed else (),
        edges=tuple(edges_named(problem, domain.edges, room.boundary)),
        soft=frozenset(relaxed),
        floor=(min(SOFT_FLOOR, hi[0]), min(SOFT_FLOOR, hi[1])) if soft else (0.0, 0.0),
        may_wrap=room.max_rects != 1,
    )


def shape_allowance(room: Room) -> int:
    """The rectangles a room's shape may have: its `max_rects`, or `DEFAULT_MAX_RECTS`
    (an L or a T) when the brief leaves it open."""
    return room.max_rects if room.max_rects is not None else DEFAULT_MAX_RECTS


def wing_names(room_id: str, count: int) -> tuple[str, ...]:
    """The names of a room's extra rectangles at level 1."""
    return tuple(f"{room_id}{WING_MARK}{k + 1}" for k in range(count))


def wings_wanted(problem: Problem) -> dict[str, int]:
    """The extra rectangles rooms ask for up front (`shape: free`, `max_rects`)."""
    return {room.id: room.rectangles - 1 for room in problem.rooms if room.rectangles > 1}


def may_start_as_l(room: Room) -> bool:
    """Whether a room may be started as an L (``shape: free``) without the brief asking:
    it starts as one rectangle, may have more, and is not fixed."""
    return room.rectangles == 1 and shape_allowance(room) > 1 and room.fixed is None


def started_as_l(problem: Problem, room_id: str) -> Problem:
    """`problem` with room `room_id` starting as an L, as ``shape: free`` asks."""
    return problem.model_copy(update={"rooms": [
        r.model_copy(update={"shape": "free"}) if r.id == room_id else r
        for r in problem.rooms]})


def unfitting_targets(problem: Problem, domain: Domain) -> list[str]:
    """Rooms whose target rectangle fits nowhere in the free floor (a living room as
    tall as the outline's only in an arm narrower than it): in the plan they came from,
    they are L- or T-shaped, so they start with a wing (docs/method.md, "Rooms of
    several rectangles"). A rectangle that fits can slide left and down until its corner
    meets the x and y of outline corners, so those corners are the only places to
    try."""
    free = domain.free
    xs = sorted({x for g in getattr(free, "geoms", [free]) for x, _ in g.exterior.coords})
    ys = sorted({y for g in getattr(free, "geoms", [free]) for _, y in g.exterior.coords})
    prepared = shapely.prepared.prep(free.buffer(1e-6))
    out = []
    for room in problem.rooms:
        if room.target_size is None or shape_allowance(room) < 2:
            continue
        tw, td = room.target_size
        if not any(prepared.contains(box(x, y, x + tw, y + td)) for x in xs for y in ys):
            out.append(room.id)
    return out


def demand_order(problem: Problem) -> list[str]:
    """Rooms by how much is asked of them, most first: adjacencies (each partner of an
    `any_of` counts a little), boundary walls and guide points. A room pinned by many
    demands is the one a single rectangle most often cannot satisfy."""
    load = {room.id: float(len(room.boundary) > 0) + len(room.positions)
            for room in problem.rooms}
    for adj in problem.adjacency:
        load[adj.a] += 1
        for p in adj.partners:
            load[p] += 1 / len(adj.partners)
    # Larger rooms first among equals: they have the floor space for a wing.
    area = {room.id: _aimed_area(room) for room in problem.rooms}
    return sorted(load, key=lambda r: (-load[r], -area[r], r))


def wing_order(problem: Problem) -> list[str]:
    """Rooms in the order they get extra rectangles when one rectangle per room cannot
    do: the largest target first (a room's target is its bounding box, so a room a
    plan draws as an L asks for more floor than it covers; in briefs extracted from
    plans that is most often the living room, the largest), then by demands
    (`demand_order`). On the planted briefs that needed wings, the largest rooms'
    wings were the layouts SCIP found soonest (on a 12-room brief needing two Ls, the
    living room's and a bedroom's wings in 3 s, where the corridor's, the room with the
    most demands, found nothing in 15 s: bench/NOTES.md, "A proof for the user's bounds,
    wings to the largest rooms, gaps laid out afresh")."""
    rank = {room_id: k for k, room_id in enumerate(demand_order(problem))}
    area = {room.id: _aimed_area(room) for room in problem.rooms}
    return sorted(rank, key=lambda r: (-area[r], rank[r]))


def _aimed_area(room: Room) -> float:
    """The area of a room's target box, else of its maximum, else 1 m²."""
    return math.prod(room.target_size or room.max_size or (1.0, 1.0))


def reach_wing(problem: Problem, domain: Domain, room: Room, main: Box, gap: Polygon
               ) -> tuple[float, Box, Box] | None:
    """A start for a wing of `room` reaching into `gap` from its rectangle `main`: the
    largest rectangle of the gap along one side of `main` (at least `WING_JOIN` long and
    `WING_MIN` deep), with `main` shortened on its far side just enough for the room's
    bounding box to keep within its maximum. The floor `main` gives up lies open, where
    neighbours can grow, unlike a pocket beside a shaft. Returns the area gained (the
    wing's less what `main` gives up), the shortened `main` and the wing; None when no
    side borders the gap so, or the shortened part would lose the room's minimum size,
    a guide point or its exterior wall."""
    lo, hi = size_bounds(room, domain, None)
    edges = edges_named(problem, domain.edges, room.boundary)
    inside = gap.buffer(1e-6)
    rings = [gap.exterior, *gap.interiors]
    xs = sorted({x for ring in rings for x, _ in ring.coords})
    ys = sorted({y for ring in rings for _, y in ring.coords})
    best: tuple[float, float, Box, Box] | None = None
    for wing in _wings_along(main, xs, ys, reach=(hi[0] - lo[0], hi[1] - lo[1])):
        if not inside.contains(wing.to_polygon()):
            continue
        rest = _kept_within(main, wing, hi)
        if rest.width < lo[0] - 1e-9 or rest.depth < lo[1] - 1e-9:
            continue
        if not all(rest.contains_point(*p) for p in room.positions):
            continue
        if edges and not any(on_edge(rest, e) for e in edges):
            continue
        gained = wing.area - (main.area - rest.area)
        if best is None or (gained, wing.area) > best[:2]:
            best = (gained, wing.area, rest, wing)
    return None if best is None else (best[0], best[2], best[3])


def _wings_along(main: Box, xs: list[float], ys: list[float], reach: tuple[float, float]
                 ) -> list[Box]:
    """Every candidate wing on a side of `main`: spans between the
    gap's vertex coordinates along the side, depths to its coordinates across, each
    at most `reach` (the room's maximum less its minimum on that axis)."""
    def spans(cuts: list[float], lo: float, hi: float) -> list[tuple[float, float]]:
        inner = sorted({lo, hi, *(c for c in cuts if lo < c < hi)})
        return [(a, b) for i, a in enumerate(inner) for b in inner[i + 1:]
                if b - a >= WING_JOIN - 1e-9]

    def depths(cuts: list[float], limit: float) -> list[float]:
        return [d for d in cuts if WING_MIN - 1e-9 <= d <= limit + 1e-9]

    found = []
    for a, b in spans(xs, main.x0, main.x1):
        found += [Box(a, main.y1, b, main.y1 + d)
                  for d in depths([y - main.y1 for y in ys], reach[1])]
        found += [Box(a, main.y0 - d, b, main.y0)
                  for d in depths([main.y0 - y for y in ys], reach[1])]
    for a, b in spans(ys, main.y0, main.y1):
        found += [Box(main.x1, a, main.x1 + d, b)
                  for d in depths([x - main.x1 for x in xs], reach[0])]
        found += [Box(main.x0 - d, a, main.x0, b)
                  for d in depths([main.x0 - x for x in xs], reach[0])]
    return found


def _kept_within(main: Box, wing: Box, hi: tuple[float, float]) -> Box:
    """`main` shortened on the side away from `wing` until both fit in `hi`."""
    x0, y0, x1, y1 = main.x0, main.y0, main.x1, main.y1
    if wing.y0 >= main.y1 - 1e-9:
        y0 = max(y0, wing.y1 - hi[1])
    elif wing.y1 <= main.y0 + 1e-9:
        y1 = min(y1, wing.y0 + hi[1])
    elif wing.x0 >= main.x1 - 1e-9:
        x0 = max(x0, wing.x1 - hi[0])
    else:
        x1 = min(x1, wing.x0 + hi[0])
    return Box(x0, y0, x1, y1)
