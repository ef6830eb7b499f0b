"""Level 1 of the hierarchy: one rectangle per room (paper Sec. 5.1-5.2), and the
size-window heuristic of Sec. 5.4 that makes SCIP find a first layout quickly."""

from __future__ import annotations

import math

from models import Problem, Room
from solver.formulation import ContactSpec, LevelSpec, RectSpec
from solver.geometry import Domain, edges_named

#: Sec. 5.4: with targets, start the size bounds at 90-110 % of the target ...
WINDOW_START = 0.10
#: ... and widen them by 10 % of the target at each failed attempt.
WINDOW_STEP = 0.10


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


def level_one_spec(problem: Problem, domain: Domain, *, window: float | None) -> LevelSpec:
    """Level 1: every room one rectangle, every constraint of the request."""
    rects = []
    for room in problem.rooms:
        lo, hi = size_bounds(room, domain, window)
        rects.append(RectSpec(
            name=room.id,
            room=room.id,
            min_size=lo,
            max_size=hi,
            target=room.target_size,
            aspect_ratio=room.aspect_ratio,
            positions=tuple(room.positions),
            edges=tuple(edges_named(problem, domain.edges, room.boundary)),
        ))
    contacts = tuple(
        ContactSpec(
            name=f"adj{k}",
            a=(adj.a,),
            partners=tuple((p,) for p in adj.partners),
            min_contact=adj.min_contact,
        )
        for k, adj in enumerate(problem.adjacency)
    )
    return LevelSpec(
        name=f"{problem.name}/level1",
        region=domain.bbox,
        blocked=domain.blocked,
        free_area=domain.area,
        rects=tuple(rects),
        contacts=contacts,
        cover_weight=problem.weights.cover,
        size_weight=problem.weights.size,
    )
