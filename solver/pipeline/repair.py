"""Gaps the hierarchy cannot close, laid out afresh (docs/method.md, "The steps", step 4).

The refinement of Sec. 5.3 only grows rooms (C_refine): a gap beside rooms at their
maximum size stays open level after level, re-solving the same sub-domain (a corner of a
U-shaped floor left between a bedroom at its largest depth and an L at its largest
width: bench/NOTES.md, "A proof for the user's bounds, wings to the largest rooms, gaps
laid out afresh"). Here the rooms around the gaps are freed and laid out again around
the others, held where they are, by the edit's MIQP (solver/pipeline/edit.py): their own
constraints, their adjacencies to the held rooms, extra rectangles where one is not
enough, and coverage in the objective. Kept only when the whole layout passes the
checker and covers more.
"""

from __future__ import annotations

import time

from shapely.geometry import Polygon

from floorplan.models import Problem
from floorplan.solver.events import Phase
from floorplan.solver.geometry import Domain
from floorplan.solver.heuristics.reshape.needs import shape_of
from floorplan.solver.pipeline.edit import solve_edit
from floorplan.solver.pipeline.fixed import has_fixed
from floorplan.solver.pipeline.hierarchy import (
    GAP_AREA,
    Piece,
    as_pieces,
    room_boxes,
    touching,
    uncovered_gaps,
)
from floorplan.solver.pipeline.run import Run, covered, covers
from floorplan.solver.verify.checker import check_layout

#: Rings of neighbours freed besides the rooms along the gaps, tried in turn: one more
#: ring is a larger MIQP that the edit's time may not solve.
RINGS = (0, 1)
#: Seconds at least left before the deadline for an attempt to start.
LEAST_SECONDS = 0.2


def repaired(run: Run, domain: Domain, pieces: list[Piece]) -> list[Piece]:
    """`pieces`, or a layout with the rooms around its gaps laid out again when they
    miss the coverage goal: the first that meets it, else the one covering most, when
    it covers more than `pieces` and passes the checker."""
    problem = run.problem
    rooms = room_boxes(pieces)
    if covers(domain, rooms) or run.soft or run.stopped() or has_fixed(problem):
        return pieces
    shapes = {r: shape_of(boxes) for r, boxes in rooms.items()}
    polygons = {r: shape for r, shape in shapes.items() if shape is not None}
    if len(polygons) < len(shapes):
        return pieces  # a room of rectangles that are not one polygon cannot be held
    gaps = uncovered_gaps(domain, pieces)
    freed = {r for r, shape in polygons.items() if any(touching(shape, gap) for gap in gaps)}
    best, most = pieces, covered(domain, rooms) + GAP_AREA
    for ring in RINGS:
        if ring:
            freed |= {r for r, shape in polygons.items()
                      if any(touching(shape, polygons[f]) for f in freed)}
        if (not freed or len(freed) == len(rooms) or run.stopped()
                or run.deadline - time.monotonic() < LEAST_SECONDS):
            break
        held = {r: boxes for r, boxes in rooms.items() if r not in freed}
        pinned = _holding(problem, {r: polygons[r] for r in held})
        result = solve_edit(pinned, held, deadline=run.deadline,
                            start={r: rooms[r] for r in freed},
                            should_stop=run.should_stop)
        outcome = "no layout" if result.rooms is None else "nothing better"
        if result.rooms is not None:
            new = {**held, **result.rooms}
            area = covered(domain, new)
            if area > most and check_layout(problem, new).valid:
                best, most = as_pieces(new), area
                run.incumbent(domain, new)
                outcome = f"coverage {area / domain.area:.1%}"
        run.emit(Phase.LEVEL, detail=f"gaps laid out afresh with {', '.join(sorted(freed))} "
                                     f"free: {outcome}")
        if covers(domain, room_boxes(best)):
            break
    return best


def _holding(problem: Problem, held: dict[str, Polygon]) -> Problem:
    """`problem` with the `held` rooms fixed at their polygons (the edit lays out the
    others). Not validated again: the polygons come from a layout of the problem."""
    return problem.model_copy(update={"rooms": [
        room.model_copy(update={"fixed": list(held[room.id].exterior.coords)[:-1]})
        if room.id in held else room for room in problem.rooms]})
