"""Level 1 of the hierarchy: one rectangle per room (paper Sec. 5.1-5.2), and the
size-window heuristic of Sec. 5.4 that makes SCIP find a first layout quickly."""

from __future__ import annotations

import math
from collections.abc import Mapping

from shapely.geometry import LineString, Polygon

from models import Problem, Room
from solver.formulation import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec
from solver.geometry import Box, Domain, edges_named
from solver.hierarchy import on_edge
from solver.soft import adjacency_soft, room_soft

#: Sec. 5.4: with targets, start the size bounds at 90-110 % of the target ...
WINDOW_START = 0.10
#: ... and widen them by 10 % of the target at each failed attempt.
WINDOW_STEP = 0.10
#: An extra rectangle of a room shares at least this much wall with its main one
#: (metres): wide enough to walk through, so the room stays one usable space ...
WING_JOIN = 1.2
#: ... and is at least this wide and deep (metres).
WING_MIN = 1.0
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
    wings: Mapping[str, int] | None = None, soft: bool = False,
) -> LevelSpec:
    """Level 1: every room one rectangle, every constraint of the request; a room in
    `wings` gets that many more rectangles (issue 8), each sharing at least
    `WING_JOIN` metres of wall with the room's main rectangle, which answers for the
    room's guide points, boundary and target, while its size maximum and aspect ratio
    hold on the bounding box of all of them (an exact envelope). With `soft`, the
    problem's soft constraints get slacks priced at `Weights.violation` per metre."""
    wings = wings or {}
    rects = []
    contacts: list[ContactSpec] = []
    envelopes = []
    for room in problem.rooms:
        lo, hi = size_bounds(room, domain, window)
        extra = wing_names(room.id, wings.get(room.id, 0))
        relaxed = room_soft(problem, room) if soft else frozenset()
        rects.append(RectSpec(
            name=room.id,
            room=room.id,
            min_size=lo,
            max_size=hi,
            target=room.target_size,
            aspect_ratio=None if extra else room.aspect_ratio,
            positions=tuple(room.positions),
            edges=tuple(edges_named(problem, domain.edges, room.boundary)),
            soft=frozenset(relaxed),
            floor=(min(SOFT_FLOOR, hi[0]), min(SOFT_FLOOR, hi[1])) if soft else (0.0, 0.0),
        ))
        for name in extra:
            rects.append(RectSpec(name=name, room=room.id, min_size=(WING_MIN, WING_MIN),
                                  max_size=hi, target=(WING_MIN, WING_MIN)))
            contacts.append(ContactSpec(name=f"join[{name}]", a=(name,),
                                        partners=((room.id,),), min_contact=WING_JOIN))
        if extra:
            envelopes.append(EnvelopeSpec(room.id, (room.id, *extra), None, hi,
                                          room.aspect_ratio, soft=frozenset(relaxed)))

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
    return LevelSpec(
        name=f"{problem.name}/level1",
        region=domain.bbox,
        blocked=domain.blocked,
        free_area=domain.area,
        rects=tuple(rects),
        contacts=tuple(contacts),
        envelopes=tuple(envelopes),
        cover_weight=problem.weights.cover,
        size_weight=problem.weights.size,
        violation_weight=problem.weights.violation if soft else 0.0,
    )


def wing_names(room_id: str, count: int) -> tuple[str, ...]:
    """The names of a room's extra rectangles at level 1."""
    return tuple(f"{room_id}{WING_MARK}{k + 1}" for k in range(count))


def wings_wanted(problem: Problem) -> dict[str, int]:
    """The extra rectangles rooms ask for up front (`shape: free`, `max_rects`)."""
    return {room.id: room.rectangles - 1 for room in problem.rooms if room.rectangles > 1}


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
    area = {room.id: math.prod(room.target_size or room.max_size or (1.0, 1.0))
            for room in problem.rooms}
    return sorted(load, key=lambda r: (-load[r], -area[r], r))


def carve_wing(problem: Problem, domain: Domain, room: Room, main: Box, gap: Polygon
               ) -> tuple[float, Box, Box] | None:
    """A start for a wing that may reach into `gap`: the strip `WING_MIN` deep along
    the side of the room's rectangle `main` that borders the gap, and what is left of
    `main`, with the length of that border. The room covers what it covered; the rest
    must still meet the room's minimum size and hold its guide points and exterior
    wall, which stay with the main rectangle. None when no side borders the gap over
    `WING_MIN` or more, or the rest would fail."""
    lo, _ = size_bounds(room, domain, None)
    edges = edges_named(problem, domain.edges, room.boundary)
    best: tuple[float, Box, Box] | None = None
    sides = {
        "south": (LineString([(main.x0, main.y0), (main.x1, main.y0)]),
                  Box(main.x0, main.y0, main.x1, main.y0 + WING_MIN),
                  Box(main.x0, main.y0 + WING_MIN, main.x1, main.y1)),
        "north": (LineString([(main.x0, main.y1), (main.x1, main.y1)]),
                  Box(main.x0, main.y1 - WING_MIN, main.x1, main.y1),
                  Box(main.x0, main.y0, main.x1, main.y1 - WING_MIN)),
        "west": (LineString([(main.x0, main.y0), (main.x0, main.y1)]),
                 Box(main.x0, main.y0, main.x0 + WING_MIN, main.y1),
                 Box(main.x0 + WING_MIN, main.y0, main.x1, main.y1)),
        "east": (LineString([(main.x1, main.y0), (main.x1, main.y1)]),
                 Box(main.x1 - WING_MIN, main.y0, main.x1, main.y1),
                 Box(main.x0, main.y0, main.x1 - WING_MIN, main.y1)),
    }
    for side, strip, rest in sides.values():
        border = side.intersection(gap.buffer(1e-6)).length
        if border < WING_MIN or min(strip.width, strip.depth) < WING_MIN - 1e-9:
            continue
        if max(strip.width, strip.depth) < WING_JOIN or rest.width < lo[0] - 1e-9 \
                or rest.depth < lo[1] - 1e-9:
            continue
        if not all(rest.contains_point(*p) for p in room.positions):
            continue
        if edges and not any(on_edge(rest, e) for e in edges):
            continue
        if best is None or border > best[0]:
            best = (border, rest, strip)
    return best
