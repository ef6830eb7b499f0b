"""The guillotine search's score: E_size (Eq. 6) on bounding boxes, the relative area
error and a small price per extra rectangle, plus every hard constraint a room can break
(C_size Eq. 5, C_ratio Eq. 7, C_pos Eq. 8, C_boundary Eq. 9, C_adj Eq. 10, a connected
shape within its rectangle cap and arms wide enough) priced by its shortfall; the
count of broken constraints beside it."""

from __future__ import annotations

import math

from floorplan.solver.heuristics.guillotine.brief import EPS, Brief, Rect, State
from floorplan.solver.heuristics.guillotine.tree import clipped, merged, room_rects

#: Weight of a room's relative area error. Linear (as in the reshaping), not squared: an
#: L's area always falls short of its bounding box's target, and a squared error would
#: have its neighbours shrink to share that shortfall, where the mean error rises.
AREA_WEIGHT = 10.0
#: Price per rectangle beyond a room's first: of two shapes equally near, the simpler.
RECT_PRICE = 0.1
#: Price per metre (or unit of ratio) of a hard constraint's shortfall, and per broken
#: constraint: far above any size error, so the search leaves them first.
SHORTFALL_PRICE = 40.0
BROKEN_PRICE = 10.0


def _walls(a: Rect, b: Rect) -> tuple[int, float, float, float] | None:
    """The wall rectangles a and b share: (axis, line, lo, hi), or None."""
    if abs(a[2] - b[0]) < EPS or abs(b[2] - a[0]) < EPS:
        lo, hi = max(a[1], b[1]), min(a[3], b[3])
        if hi - lo > EPS:
            return 0, a[2] if abs(a[2] - b[0]) < EPS else a[0], lo, hi
    if abs(a[3] - b[1]) < EPS or abs(b[3] - a[1]) < EPS:
        lo, hi = max(a[0], b[0]), min(a[2], b[2])
        if hi - lo > EPS:
            return 1, a[3] if abs(a[3] - b[1]) < EPS else a[1], lo, hi
    return None


def _thickness(rect: Rect) -> float:
    """The shorter side of `rect`."""
    return min(rect[2] - rect[0], rect[3] - rect[1])


def _connected(rects: list[Rect], wall: float) -> bool:
    """Whether the rectangles make one shape, each joined to the next by a wall at least
    `wall` long (an L's arms meet over their width, not at a point)."""
    reached = {0}
    todo = [0]
    while todo:
        i = todo.pop()
        for j in range(len(rects)):
            shared = _walls(rects[i], rects[j]) if j not in reached else None
            if shared is not None and shared[3] - shared[2] >= wall - EPS:
                reached.add(j)
                todo.append(j)
    return len(reached) == len(rects)


def _contact(a: list[Rect], b: list[Rect]) -> float:
    """The longest straight wall rooms a and b share, as `geometry.contact_length`
    measures C_adj for the checker, on plain tuples: it runs for every adjacency at
    every step, where shapely would cost more than the rest of the step."""
    if len(a) == 1 and len(b) == 1:
        wall = _walls(a[0], b[0])
        return 0.0 if wall is None else wall[3] - wall[2]
    lines: dict[tuple[int, float], list[tuple[float, float]]] = {}
    for ra in a:
        for rb in b:
            wall = _walls(ra, rb)
            if wall is not None:
                lines.setdefault((wall[0], round(wall[1], 6)), []).append((wall[2], wall[3]))
    best = 0.0
    for spans in lines.values():
        spans.sort()
        lo, hi = spans[0]
        for s, t in spans[1:]:
            if s <= hi + EPS:
                hi = max(hi, t)
            else:
                best, lo, hi = max(best, hi - lo), s, t
        best = max(best, hi - lo)
    return best


def _edge_gap(rects: list[Rect], edges: tuple[tuple[str, float, float, float], ...]) -> float:
    """How far the room is from running along one of its named outline edges (0: it
    does)."""
    best = math.inf
    for facing, line, lo, hi in edges:
        for x0, y0, x1, y1 in rects:
            if facing in ("north", "south"):
                gap, span = abs(line - (y1 if facing == "north" else y0)), min(x1, hi) - max(x0, lo)
            else:
                gap, span = abs(line - (x1 if facing == "east" else x0)), min(y1, hi) - max(y0, lo)
            if gap < EPS and span > EPS:
                return 0.0
            best = min(best, gap + max(0.0, -span) + 0.1)
    return best


def _point_gap(rects: list[Rect], x: float, y: float) -> float:
    return min(math.hypot(max(r[0] - x, 0.0, x - r[2]), max(r[1] - y, 0.0, y - r[3]))
               for r in rects)


def score_state(brief: Brief, state: State) -> tuple[float, int]:
    """`score_layout` of the layout under `state`."""
    if not brief.outside:  # nothing cut: the rooms are the tree's own parts
        rooms = room_rects(brief, state)
        return score_layout(brief, rooms, rooms)
    parts: list[list[Rect]] = [[] for _ in brief.ids]
    return score_layout(brief, room_rects(brief, state, parts), parts)


def score_layout(brief: Brief, rooms: list[list[Rect]], parts: list[list[Rect]]
                 ) -> tuple[float, int]:
    """The energy the annealing lowers, and how many hard constraints are broken, of
    `rooms` whose rectangles before the outline cut them are `parts`."""
    energy = shortfall = 0.0
    broken = 0
    shapes: list[list[Rect]] = []
    n = len(brief.needs)
    for void, rects in zip(brief.voids, rooms[n:n + len(brief.voids)], strict=True):
        # A void must be the very notch of the outline: elsewhere rooms would cover it.
        miss = (sum(abs(a - b) for a, b in zip(rects[0], void, strict=True))
                if len(rects) == 1 else 10.0)
        if miss > EPS:
            broken += 1
            shortfall += miss
    for rects in rooms[n + len(brief.voids):]:
        # A filler must lie outside the outline: inside it, it is floor no room has.
        inside = sum((r[2] - r[0]) * (r[3] - r[1]) for r in clipped(rects, brief.outside))
        if inside > EPS:
            broken += 1
            shortfall += inside
    for needs, rects, own in zip(brief.needs, rooms, parts, strict=False):
        rects = merged(rects) if len(rects) > 1 else rects
        shapes.append(rects)
        if not rects:
            broken += 1
            shortfall += 10.0
            continue
        if len(rects) == 1:
            x0, y0, x1, y1 = rects[0]
            w, d = x1 - x0, y1 - y0
            area = w * d
        else:
            x0 = min(r[0] for r in rects)
            y0 = min(r[1] for r in rects)
            w = max(r[2] for r in rects) - x0
            d = max(r[3] for r in rects) - y0
            area = sum((r[2] - r[0]) * (r[3] - r[1]) for r in rects)
        tw, td = needs.target
        error = (area - needs.area) / needs.area
        energy += (w - tw) ** 2 + (d - td) ** 2 + AREA_WEIGHT * abs(error)
        energy += RECT_PRICE * (len(rects) - 1)
        miss = (max(0.0, needs.lo[0] - w) + max(0.0, w - needs.hi[0])
                + max(0.0, needs.lo[1] - d) + max(0.0, d - needs.hi[1]))
        if needs.ratio is not None:
            long, short = max(w, d), min(w, d)
            miss += (max(0.0, needs.ratio[0] * short - long)
                     + max(0.0, long - needs.ratio[1] * short))
        if len(rects) > 1:
            miss += max(0, len(rects) - needs.cap) * 2.0
            # The arms the tree made: what the outline cut off them may be thinner, and
            # then meets the rest over its own width.
            made, wall = rects, needs.arm
            if brief.outside:
                made = merged(own)
                wall = min(needs.arm, *(_thickness(r) for r in rects))
            elif brief.voids:
                # A part touching a void (a notch) may be as thin as the notch leaves
                # it, as a part the outline cut may in the other model (docs/method.md,
                # 'Whole layouts by guillotine cuts').
                made = [r for r in rects if not any(_walls(r, v) for v in brief.voids)]
            miss += sum(max(0.0, needs.arm - _thickness(r)) for r in made)
            if not _connected(rects, wall):
                miss += 5.0
        for x, y in needs.points:
            miss += _point_gap(rects, x, y)
        if needs.edges:
            miss += _edge_gap(rects, needs.edges)
        if miss > EPS:
            broken += 1
            shortfall += miss
    for a, partners, wanted in brief.adjacency:
        if len(partners) == 1:
            best = _contact(shapes[a], shapes[partners[0]])
        else:
            best = max((_contact(shapes[a], shapes[b]) for b in partners), default=0.0)
        if best < wanted - EPS or best <= EPS:
            broken += 1
            shortfall += wanted - best + (0.5 if best <= EPS else 0.0)
    return energy + SHORTFALL_PRICE * shortfall + BROKEN_PRICE * broken, broken
