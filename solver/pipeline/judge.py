"""SCIP judges the answer (docs/method.md, "SCIP has the last word"): whatever found the
layout (level 1, refinement levels, tilings, the guillotine search, the reshaping), it
is handed as a start to the MIQP of the whole floor with its rooms' rectangles as they
are, and SCIP's answer to that model is the layout returned, with its bound.

The model (`final_spec`) is level 1's (Sec. 5.1-5.2) with every rectangle of the layout
a variable rectangle: a room of one rectangle keeps every constraint and its target,
exactly as at level 1; a room of several keeps its size, ratio and guide points on the
exact bounding box of its rectangles (C_envelope), its exterior wall on the rectangle
that has it, its rectangles joined along the walls they share, and each rectangle aims
at its own size, as refinement levels aim their halves (docs/method.md, "Deviations
from the paper"). SCIP then polishes the layout with its own heuristics and branching
until it proves it optimal, or until the stage stalls.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence

from floorplan.models import Problem
from floorplan.solver.events import Phase
from floorplan.solver.geometry import Box, Domain, edges_named, on_edge
from floorplan.solver.heuristics.level_one import size_bounds
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.scip_run import Incumbent, LevelStatus, add_start
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec
from floorplan.solver.pipeline.run import Run, ScipAnswer, layout_objective

#: Separates a room's id from the number of one of its rectangles in the final model.
PART_MARK = "~part"
#: Rectangles of one room sharing at least this much wall (metres) stay joined by that
#: much, or by what they share when less: the room stays one piece of floor.
JOIN = 0.9
#: Walls closer than this (metres) count as shared when the joins are found.
TOUCH = 1e-4
#: The judge is not built above this many rectangles: SCIP's model grows with their
#: pairs, and on large floors building it costs more than polishing gains.
MAX_RECTS = 60
#: Eq. 12 at or below this is zero (m², rounding of the output's walls).
ZERO = 1e-9
#: Seconds SCIP has at least, when time is left, to confirm the start and look around it
#: ...
MIN_SECONDS = 0.2
#: ... and this share of the time the solve has spent more, unless the user asked for
#: the whole limit: SCIP rarely improves a polished layout, and its proof of optimality
#: on a floor of a dozen rooms would take far longer than the limit.
SPENT_SHARE = 0.05


def part_names(room_id: str, count: int) -> list[str]:
    """The names of a room's rectangles in the final model: the room's id for the first
    (a room of one rectangle is named as at level 1)."""
    return [room_id, *(f"{room_id}{PART_MARK}{k}" for k in range(1, count))]


def final_spec(problem: Problem, domain: Domain,
               rooms: Mapping[str, Sequence[Box]]) -> tuple[LevelSpec, dict[str, Box]] | None:
    """The whole floor's MIQP with the rectangles of `rooms`, and the start naming them;
    None when a room's exterior wall lies on none of its rectangles' whole sides
    (Eq. 9 asks for a whole side: such a layout is no solution of any level's model)."""
    rects: list[RectSpec] = []
    contacts: list[ContactSpec] = []
    envelopes: list[EnvelopeSpec] = []
    start: dict[str, Box] = {}
    parts: dict[str, tuple[str, ...]] = {}
    for room in problem.rooms:
        boxes = sorted(rooms[room.id], key=lambda b: -b.area)
        names = part_names(room.id, len(boxes))
        parts[room.id] = tuple(names)
        start.update(zip(names, boxes, strict=True))
        lo, hi = size_bounds(room, domain, None)
        edges = tuple(edges_named(problem, domain.edges, room.boundary))
        if len(boxes) == 1:
            rects.append(RectSpec(
                name=room.id, room=room.id, min_size=lo, max_size=hi,
                target=room.target_size, aspect_ratio=room.aspect_ratio,
                positions=tuple(room.positions), edges=edges, may_wrap=False))
            continue
        walled = next((k for k, b in enumerate(boxes) if any(on_edge(b, e) for e in edges)),
                      None) if edges else None
        if edges and walled is None:
            return None
        for k, (name, b) in enumerate(zip(names, boxes, strict=True)):
            rects.append(RectSpec(
                name=name, room=room.id,
                min_size=(min(JOIN, b.width), min(JOIN, b.depth)), max_size=hi,
                target=(b.width, b.depth), edges=edges if k == walled else (),
                may_wrap=False))
        contacts += _joins(names, boxes)
        envelopes.append(EnvelopeSpec(room.id, tuple(names), None, hi, room.aspect_ratio,
                                      min_size=lo, positions=tuple(room.positions)))
    contacts += [
        ContactSpec(name=f"adj{k}", a=parts[adj.a],
                    partners=tuple(parts[p] for p in adj.partners),
                    min_contact=adj.min_contact)
        for k, adj in enumerate(problem.adjacency)]
    spec = LevelSpec(
        name=f"{problem.name}/final", region=domain.bbox, blocked=tuple(domain.blocked),
        free_area=domain.area, rects=tuple(rects), contacts=tuple(contacts),
        envelopes=tuple(envelopes), cover_weight=problem.weights.cover,
        size_weight=problem.weights.size)
    return spec, start


def _joins(names: Sequence[str], boxes: Sequence[Box]) -> list[ContactSpec]:
    """Contacts keeping a room's rectangles joined: a spanning tree of the walls they
    share in the start, each kept at `JOIN` metres or what it is when less."""
    joined, joins = {0}, []
    while len(joined) < len(boxes):
        best = max(((shared(boxes[i], boxes[j]), i, j) for i in joined
                    for j in range(len(boxes)) if j not in joined), default=None)
        if best is None or best[0] <= TOUCH:
            break  # a room in pieces: its envelope still holds it together
        length, i, j = best
        joined.add(j)
        joins.append(ContactSpec(name=f"join[{names[j]}]", a=(names[j],),
                                 partners=((names[i],),),
                                 min_contact=min(JOIN, length) * (1 - 1e-6)))
    return joins


def shared(a: Box, b: Box) -> float:
    """Length of the wall two rectangles share (0 when they only meet at a corner)."""
    if abs(a.x1 - b.x0) <= TOUCH or abs(b.x1 - a.x0) <= TOUCH:
        return max(0.0, min(a.y1, b.y1) - max(a.y0, b.y0))
    if abs(a.y1 - b.y0) <= TOUCH or abs(b.y1 - a.y0) <= TOUCH:
        return max(0.0, min(a.x1, b.x1) - max(a.x0, b.x0))
    return 0.0


def is_eq12(problem: Problem, spec: LevelSpec) -> bool:
    """Whether the model's objective is Eq. 12 itself: every room one rectangle with a
    target (a room of several aims its rectangles at their own sizes instead)."""
    return len(spec.rects) == len(problem.rooms) and all(
        r.target is not None for r in spec.rects)


def judged(run: Run, domain: Domain, rooms: dict[str, list[Box]], deadline: float
           ) -> dict[str, list[Box]]:
    """`rooms` handed to SCIP as a start of the whole floor's MIQP (`final_spec`), and
    SCIP's best answer to it: the start itself, or a layout SCIP found from it with a
    lower Eq. 12. Records what SCIP says of it (`Run.scip_answer`). The layout comes
    back unchanged when it is no solution of the model (SCIP refuses the start), when
    the floor is too large to judge, or when the solve was stopped."""
    problem = run.problem
    if run.soft or run.stopped() or sum(len(b) for b in rooms.values()) > MAX_RECTS or set(
            rooms) != {r.id for r in problem.rooms}:
        return rooms
    built = final_spec(problem, domain, rooms)
    if built is None:
        run.emit(Phase.LEVEL, detail="SCIP's check: a room's exterior wall is not a whole "
                 "side of one of its rectangles; the layout stays the heuristics'")
        return rooms
    spec, start_boxes = built
    lm = build_level(spec)
    owner = {r.name: r.room for r in spec.rects}

    def as_rooms(rects: Mapping[str, Box]) -> dict[str, list[Box]]:
        out: dict[str, list[Box]] = {}
        for name, b in rects.items():
            out.setdefault(owner[name], []).append(b)
        return out

    run.begin_stage()
    # The start in closed form, checked by SCIP: no solve.
    start = add_start(lm, start_boxes)
    if start.values is None:
        run.emit(Phase.LEVEL, detail="SCIP's check: the layout breaks a constraint of the "
                 "whole floor's model; it stays the heuristics'")
        return rooms
    before = layout_objective(problem, domain, rooms)
    if before <= ZERO:
        # Eq. 12 and the model's objective are sums of squares and uncovered floor: at
        # zero the start is optimal, a proof SCIP needs no search for.
        run.scip_answer = ScipAnswer(rooms, True, 0.0)
        run.emit(Phase.LEVEL, objective=before, detail="SCIP's check: the layout is a "
                 "solution of the whole floor's MIQP at its least objective, zero")
        return rooms
    run.emit(Phase.LEVEL, objective=before,
             detail=f"SCIP's check: the layout is a solution of the whole floor's MIQP "
                    f"({len(spec.rects)} rectangles); SCIP polishes it")

    def announce(inc: Incumbent) -> None:
        run.incumbent(domain, as_rooms(inc.rects), inc.dual_bound)

    seconds = deadline - time.monotonic()
    if problem.options.stop == "stalled":
        seconds = min(seconds, MIN_SECONDS + SPENT_SHARE * run.elapsed())
    if seconds < MIN_SECONDS / 4:
        # The limit is a ceiling: no time is left to search, the start stands unproven.
        run.scip_answer = ScipAnswer(rooms, False, None)
        return rooms
    result = run.run(lm, seconds, on_incumbent=announce)
    bound = result.dual_bound if is_eq12(problem, spec) else None
    bound = None if bound is None else max(bound, 0.0)
    if result.rects is not None:
        best = as_rooms(result.rects)
        # SCIP's best has the lowest objective of its model; the answer also may not
        # raise Eq. 12 (the two differ for rooms of several rectangles).
        if layout_objective(problem, domain, best) <= before + 1e-9:
            run.scip_answer = ScipAnswer(best, result.status is LevelStatus.OPTIMAL, bound)
            return best
    run.scip_answer = ScipAnswer(rooms, False, bound)
    return rooms
