"""The last gaps (paper Sec. 5.3's last refinement step): the floor no room covers,
absorbed by the rooms bordering it, each growing only as far as its bounds allow
(`absorb_gaps`, `absorbed`); and a room of one rectangle slid across a gap, the strip it
leaves absorbed by the rooms beyond (`slides`)."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import replace

from floorplan.models import Problem
from floorplan.solver.geometry import EPS, Box, Domain, bounding_box, rectangles_of
from floorplan.solver.pipeline.hierarchy import (
    Piece,
    as_pieces,
    merge_rectangular_pairs,
    relaxed_bounds,
    room_boxes,
    uncovered_gaps,
)

#: Passes of the last step: what one side of a gap leaves, another may take.
ABSORB_PASSES = 3
#: Thinner strips (metres) are not worth a room's extra corner.
MIN_STRIP = 0.05


def absorb_gaps(problem: Problem, domain: Domain, pieces: Sequence[Piece]) -> list[Piece]:
    """The last refinement step: each leftover gap rectangle is cut along the walls of
    the rooms bordering one of its sides, and each room takes the deepest strip of its
    cut that keeps its bounding box within its size and ratio bounds. What one side
    leaves, the next pass may take from another. Rooms only grow, so every other
    constraint keeps holding."""
    result = list(pieces)
    for _ in range(ABSORB_PASSES):
        before = len(result)
        for gap in uncovered_gaps(domain, result):
            for cell in rectangles_of(gap):
                result = _absorb_cell(problem, result, cell)
        if len(result) == before:
            break
    return merge_rectangular_pairs(result)


def absorbed(problem: Problem, domain: Domain, rooms: dict[str, list[Box]]
             ) -> dict[str, list[Box]]:
    """`absorb_gaps` on a layout given as room id -> rectangles."""
    return room_boxes(absorb_gaps(problem, domain, as_pieces(rooms)))


def slides(problem: Problem, domain: Domain, pieces: Sequence[Piece]
           ) -> Iterator[list[Piece]]:
    """Layouts with one room of a single rectangle moved across a gap that borders the
    whole of one of its sides, by the gap's depth there, and the strip it leaves
    absorbed by the rooms beyond (`absorb_gaps`): for a gap whose bordering rooms are
    all at their largest. The room keeps its size and moves only over floor no room
    covers, so nothing overlaps; what else it must keep (contacts, walls, guide points)
    is for the caller's checker."""
    shift = {"south": (0.0, 1.0), "north": (0.0, -1.0), "west": (1.0, 0.0),
             "east": (-1.0, 0.0)}
    for gap in uncovered_gaps(domain, pieces):
        for cell in rectangles_of(gap):
            for side, (fx, fy) in shift.items():
                cuts = _cuts_along(pieces, cell, side)
                if cuts is None or len(cuts) != 1:
                    continue
                room_id, part = cuts[0]
                own = [p for p in pieces if p.room == room_id]
                if len(own) != 1:
                    continue
                b = own[0].box
                whole = (abs(part.x0 - b.x0) <= EPS and abs(part.x1 - b.x1) <= EPS
                         if side in ("south", "north") else
                         abs(part.y0 - b.y0) <= EPS and abs(part.y1 - b.y1) <= EPS)
                if not whole:
                    continue
                dx, dy = fx * cell.width, fy * cell.depth
                moved = replace(own[0], box=Box(b.x0 + dx, b.y0 + dy, b.x1 + dx, b.y1 + dy))
                yield absorb_gaps(problem, domain,
                                  [moved if p is own[0] else p for p in pieces])


def _absorb_cell(problem: Problem, pieces: list[Piece], cell: Box) -> list[Piece]:
    for side in ("south", "north", "west", "east"):
        cuts = _cuts_along(pieces, cell, side)
        if cuts is None:
            continue
        grown = list(pieces)
        for room_id, part in cuts:
            own = [p.box for p in grown if p.room == room_id]
            strip = _deepest_strip(problem, room_id, own, part, side)
            if strip is not None:
                grown.append(Piece(f"{room_id}+{len(grown)}", room_id, strip))
        if len(grown) > len(pieces):
            return grown
    return pieces


def _deepest_strip(
    problem: Problem, room_id: str, own: list[Box], part: Box, side: str
) -> Box | None:
    """The deepest strip of `part`, growing away from the room on `side` of it, that
    keeps the room within bounds (the whole part when it can)."""
    grow = {"south": lambda t: Box(part.x0, part.y0, part.x1, part.y0 + t),
            "north": lambda t: Box(part.x0, part.y1 - t, part.x1, part.y1),
            "west": lambda t: Box(part.x0, part.y0, part.x0 + t, part.y1),
            "east": lambda t: Box(part.x1 - t, part.y0, part.x1, part.y1)}[side]

    now = bounding_box(own)
    # The room's bounds as they stand now: the same for every depth tried.
    max_size, aspect_ratio = relaxed_bounds(problem, room_id, now, (math.inf, math.inf))

    def fits(t: float) -> bool:
        # The bounding box of the room and the strip, in plain arithmetic: this runs
        # some thirty times a strip, for every incumbent of a solve.
        s = grow(t)
        return _box_within(Box(min(now.x0, s.x0), min(now.y0, s.y0),
                               max(now.x1, s.x1), max(now.y1, s.y1)), max_size, aspect_ratio)

    full = part.depth if side in ("south", "north") else part.width
    if fits(full):
        return grow(full)
    lo, hi = 0.0, full
    for _ in range(30):  # bisection to ~1e-9 of the depth
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return grow(lo) if lo >= MIN_STRIP and fits(lo) else None


def _cuts_along(pieces: Sequence[Piece], cell: Box, side: str) -> list[tuple[str, Box]] | None:
    """The cell cut perpendicular to `side` where the rooms bordering that side change;
    stretches of the side no room borders are left out (another side, or a later
    pass, may reach them); None when no room borders it."""
    horizontal = side in ("south", "north")
    line = {"south": cell.y0, "north": cell.y1, "west": cell.x0, "east": cell.x1}[side]
    lo, hi = (cell.x0, cell.x1) if horizontal else (cell.y0, cell.y1)
    spans = []
    for p in pieces:
        b = p.box
        touches = (abs(b.y1 - line) <= 1e-6 if side == "south" else
                   abs(b.y0 - line) <= 1e-6 if side == "north" else
                   abs(b.x1 - line) <= 1e-6 if side == "west" else abs(b.x0 - line) <= 1e-6)
        a0, a1 = (b.x0, b.x1) if horizontal else (b.y0, b.y1)
        if touches and min(a1, hi) - max(a0, lo) > 1e-6:
            spans.append((max(a0, lo), min(a1, hi), p.room))
    spans.sort()
    at, cuts = lo, []
    for s0, s1, room_id in spans:
        if s1 <= at + 1e-6:
            continue
        at = max(at, s0)
        part = (Box(at, cell.y0, s1, cell.y1) if horizontal else Box(cell.x0, at, cell.x1, s1))
        cuts.append((room_id, part))
        at = s1
    return cuts or None


def _box_within(b: Box, max_size: tuple[float, float],
                aspect_ratio: tuple[float, float] | None) -> bool:
    """Whether a room's bounding box `b` keeps to `max_size` and `aspect_ratio`."""
    if b.width > max_size[0] + 1e-9 or b.depth > max_size[1] + 1e-9:
        return False
    if aspect_ratio:
        lo, hi = aspect_ratio
        ratio = max(b.width, b.depth) / max(min(b.width, b.depth), EPS)
        if not lo - 1e-9 <= ratio <= hi + 1e-9:
            return False
    return True
