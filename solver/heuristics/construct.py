"""A first level-1 layout for problems too large for one feasibility MILP: place the
rooms a batch at a time, each batch a small MILP among the rooms already placed.

The flat MILP of 40 rooms has 780 pairs of four disjunctions and SCIP finds no
layout in a minute; a batch of eight among fixed walls solves in milliseconds. The
order keeps constrained rooms early (guide points first, then along the adjacency
graph), and a contact is imposed when the last of its rooms is placed, so every
constraint of the request holds once the last batch is in."""

from __future__ import annotations

import random
import time
from collections import deque
from collections.abc import Callable
from dataclasses import replace

from pyscipopt import quicksum

from floorplan.solver.geometry import Box, unusable_space
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.objective import e_violation
from floorplan.solver.miqp.scip_run import LevelResult, LevelStatus
from floorplan.solver.miqp.spec import LevelSpec

#: Rooms placed per batch.
BATCH = 8
#: Seconds a batch may spend packing its rooms tighter.
BATCH_LIMIT = 0.3
#: Attempts with a reshuffled order before giving up.
ATTEMPTS = 3

Step = Callable[[LevelModel, float], LevelResult]


def construct(
    spec: LevelSpec, *, deadline: float, rng: random.Random, step: Step
) -> dict[str, Box] | None:
    """A layout satisfying every constraint of the one-rectangle-per-room `spec`, or
    None when the batches could not be placed before `deadline`."""
    for attempt in range(ATTEMPTS):
        order = placement_order(spec, rng if attempt else None)
        placed = _place_in_batches(spec, order, deadline, step)
        if placed is not None:
            return placed
        if time.monotonic() >= deadline:
            break
    return None


def placement_order(spec: LevelSpec, rng: random.Random | None) -> list[str]:
    """Rooms with guide points first (their places are not negotiable), then breadth
    first along the contacts from the most connected room, then the largest first."""
    names = [r.name for r in spec.rects]
    links: dict[str, set[str]] = {n: set() for n in names}
    for c in spec.contacts:
        for n in c.members:
            links[n] |= c.members - {n}
    area = {r.name: r.min_size[0] * r.min_size[1] for r in spec.rects}
    with_points = [r.name for r in spec.rects if r.positions]
    rest = sorted(set(names) - set(with_points), key=lambda n: (-len(links[n]), -area[n], n))
    if rng is not None:
        rng.shuffle(rest)
    order: list[str] = []
    seen: set[str] = set()
    queue: deque[str] = deque(with_points)
    for start in rest:
        queue.append(start)
        while queue:
            n = queue.popleft()
            if n in seen:
                continue
            seen.add(n)
            order.append(n)
            queue.extend(sorted(links[n] - seen, key=lambda m: (-area[m], m)))
    return order


def _place_in_batches(
    spec: LevelSpec, order: list[str], deadline: float, step: Step
) -> dict[str, Box] | None:
    placed: dict[str, Box] = {}
    pending = [order[k:k + BATCH] for k in range(0, len(order), BATCH)]
    while pending:
        batch = pending.pop(0)
        left = deadline - time.monotonic()
        if left <= 0.05:
            return None
        lm = build_level(batch_spec(spec, placed, set(batch)), feasibility=True)
        _pack_tightly(lm, set(batch))
        # The first packing comes within milliseconds; a tighter one is worth a little.
        result = step(lm, min(BATCH_LIMIT, left / (len(pending) + 1)))
        if result.rects is not None:
            placed.update({n: b for n, b in result.rects.items() if n in batch})
        elif result.status is LevelStatus.NO_SOLUTION and len(batch) > 1:
            # Not proven impossible, only slow: two half batches are far easier.
            half = len(batch) // 2
            pending[:0] = [batch[:half], batch[half:]]
        else:
            return None
    return placed


def batch_spec(spec: LevelSpec, placed: dict[str, Box], batch: set[str]) -> LevelSpec:
    """`spec` restricted to the `batch`: placed rooms are walls (and fixed rectangles
    where a contact names them); a contact counts once all its rooms are present."""
    present = set(placed) | batch
    contacts = tuple(
        c for c in spec.contacts
        if c.members <= present and c.members & batch
    )
    named = {n for c in contacts for n in c.members}
    rects = tuple(
        r if r.name in batch else replace(r, fixed=placed[r.name])
        for r in spec.rects if r.name in batch or (r.name in named and r.name in placed)
    )
    smallest = min(min(r.min_size) for r in spec.rects if r.name in batch)
    return replace(spec, name=f"{spec.name}/batch", rects=rects, contacts=contacts,
                   blocked=unusable_space(spec.region, (*spec.blocked, *placed.values()),
                                          smallest))


def _pack_tightly(lm: LevelModel, batch: set[str]) -> None:
    """Rooms small and toward the south-west corner, to leave later batches the most
    room; the neighbourhood search grows them afterwards."""
    terms = []
    for name in batch:
        v = lm.rects[name]
        terms += [v.x, v.y, v.w, v.d]
    # Soft constraints' slacks keep their price (far above a metre of packing).
    lm.model.setObjective(quicksum(terms) + e_violation(lm), "minimize")
