"""Soft constraints (docs/method.md, "Soft constraints"): which constraints of a problem
may be violated, and how far rectangles are from meeting each one.

A soft constraint is kept in the MIQP with a slack variable priced at
`Weights.violation` per metre (solver/miqp/formulation.py). The shortfall of a constraint
is measured here, on plain rectangles, in the same terms as those slacks: the checker
(solver/verify/checker.py) reports it and the neighbourhood search (`level_objective`)
prices it, so the two agree with each other and with SCIP. Every shortfall is in
metres, so one price per metre serves every family.

Inside the outline, no overlap and obstacles are never soft: a layout breaking them
is not a plan.
"""

from __future__ import annotations

from collections.abc import Sequence

from floorplan.models import Adjacency, Problem, Room
from floorplan.models.problem import SoftFamily
from floorplan.solver.geometry import Box, Edge

#: A soft boundary demand met at zero slack touches its edge along at least this much
#: (metres, or half the edge when shorter), so that the checker sees a real contact.
SOFT_EDGE_CONTACT = 0.1


def room_soft(problem: Problem, room: Room) -> frozenset[SoftFamily]:
    """The families of `room`'s constraints that are soft in `problem`."""
    return room.soft_families(problem.options.strict)


def adjacency_soft(problem: Problem, adjacency: Adjacency) -> bool:
    """Whether an adjacency of `problem` is soft."""
    return adjacency.soft or not problem.options.strict


def has_soft(problem: Problem) -> bool:
    """Whether any constraint of `problem` is soft (so a violating layout may be returned)."""
    return (not problem.options.strict or any(r.soft for r in problem.rooms)
            or any(a.soft for a in problem.adjacency))


def hard_part(problem: Problem) -> Problem:
    """`problem` without its soft constraints: what must hold in any layout returned.
    The prechecks and the conflict search look at this part only."""
    if not has_soft(problem):
        return problem
    rooms = []
    for room in problem.rooms:
        soft = room_soft(problem, room)
        update: dict[str, object] = {}
        if "min_size" in soft:
            update["min_size"] = None
        if "max_size" in soft:
            update["max_size"] = None
        if "aspect_ratio" in soft:
            update["aspect_ratio"] = None
        if "positions" in soft:
            update["positions"] = []
        if "boundary" in soft:
            update["boundary"] = []
        rooms.append(room.model_copy(update=update))
    adjacency = [a for a in problem.adjacency if not adjacency_soft(problem, a)]
    return problem.model_copy(update={"rooms": rooms, "adjacency": adjacency})


# Shortfalls, metres. Each function mirrors the slack of its family in the MIQP.


def size_shortfall(size: tuple[float, float], lo: Sequence[float] | None,
                   hi: Sequence[float] | None) -> float:
    """C_size (Eq. 5): what the width and depth miss of `lo` plus what they exceed `hi`
    by, both axes added.

    >>> size_shortfall((2.0, 5.0), (3.0, 3.0), (4.0, 4.0))
    2.0
    """
    total = 0.0
    for axis in (0, 1):
        if lo is not None:
            total += max(0.0, lo[axis] - size[axis])
        if hi is not None:
            total += max(0.0, size[axis] - hi[axis])
    return total


def ratio_shortfall(size: tuple[float, float], ratio: tuple[float, float]) -> float:
    """C_ratio (Eq. 7) in its linear form: how far the long side is outside
    [lo, hi] times the short side.

    >>> ratio_shortfall((6.0, 2.0), (1.0, 2.0))
    2.0
    >>> ratio_shortfall((3.0, 2.0), (2.0, 3.0))
    1.0
    """
    lo, hi = ratio
    long, short = max(size), min(size)
    return max(0.0, lo * short - long, long - hi * short)


def point_shortfall(boxes: Sequence[Box], point: tuple[float, float]) -> float:
    """C_pos (Eq. 8): the distance from `point` to the nearest rectangle, along the
    farther axis (0 when a rectangle covers it).

    >>> point_shortfall([Box(0, 0, 2, 2)], (3.0, 2.5))
    1.0
    """
    px, py = point
    return min((max(b.x0 - px, px - b.x1, b.y0 - py, py - b.y1, 0.0) for b in boxes),
               default=0.0)


def edge_shortfall(boxes: Sequence[Box], edges: Sequence[Edge], contact: float = 0.0) -> float:
    """C_boundary (Eq. 9): the distance from the nearest rectangle to the nearest of
    `edges`, along the farther axis; with `contact`, overlapping the edge by less than
    that along it counts as a gap (the MIQP's margin).

    >>> from solver.geometry import boundary_edges
    >>> south = boundary_edges([(0, 0), (10, 0), (10, 5), (0, 5)])[0]
    >>> edge_shortfall([Box(1, 2, 3, 4)], [south])
    2.0
    """
    best = float("inf")
    for e in edges:
        lo, hi = e.span
        margin = min(contact, e.length / 2)
        for b in boxes:
            a0, a1, c0, c1 = (b.x0, b.x1, b.y0, b.y1) if e.horizontal else (b.y0, b.y1, b.x0, b.x1)
            along = max(0.0, lo + margin - a1, a0 - (hi - margin))
            across = max(0.0, c0 - e.line, e.line - c1)
            best = min(best, max(along, across))
    return 0.0 if best == float("inf") else float(best)


def contact_shortfall(a: Sequence[Box], partners: Sequence[Sequence[Box]],
                      min_contact: float) -> float:
    """C_adj (Eq. 10/11): for the best pair of rectangles of `a` and of one partner,
    the larger of the contact missing along a shared wall and the gap across it.

    >>> contact_shortfall([Box(0, 0, 2, 2)], [[Box(2, 1.5, 4, 4)]], 0.9)
    0.4
    >>> contact_shortfall([Box(0, 0, 2, 2)], [[Box(3, 0, 5, 2)]], 0.9)
    1.0
    """
    best = float("inf")
    for group in partners:
        for i in a:
            for j in group:
                along_x = min(i.x1, j.x1) - max(i.x0, j.x0)
                along_y = min(i.y1, j.y1) - max(i.y0, j.y0)
                # A horizontal wall (contact along x, touching in y) or a vertical one.
                horizontal = max(0.0, min_contact - along_x, -along_y)
                vertical = max(0.0, min_contact - along_y, -along_x)
                best = min(best, horizontal, vertical)
    return 0.0 if best == float("inf") else round(float(best), 9)
