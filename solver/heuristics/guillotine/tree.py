"""The guillotine search's slicing trees: a random one (`initial`), a tiling's
(`from_tiling`), and the rooms' rectangles under a tree (`room_rects`): every cut divides
its region in proportion to the areas asked of its two sides (`cut_region`), then the
outline cuts off what lies outside it (`clipped`); `layout_of` gives the rooms as boxes."""

from __future__ import annotations

import itertools
import random
from collections.abc import Sequence

from floorplan.solver.geometry import Box
from floorplan.solver.heuristics.guillotine.brief import (
    EPS,
    HORIZONTAL,
    VERTICAL,
    Brief,
    Rect,
    State,
)
from floorplan.solver.heuristics.tiling import Tiling

#: The L and T rooms take the floor the rectangles leave while it is at least this share
#: of their targets' area.
L_LEAST = 0.4


def initial(brief: Brief, rng: random.Random) -> State:
    """A random balanced tree over the rooms, each a rectangle asking its target area."""
    n = len(brief.ids)
    order = list(range(n))
    rng.shuffle(order)

    def build(rooms: list[int]) -> list[int]:
        if len(rooms) == 1:
            return rooms
        half = len(rooms) // 2
        return build(rooms[:half]) + build(rooms[half:]) + [rng.choice((VERTICAL, HORIZONTAL))]

    return State(build(order), [1.0] * n, [0.5] * n)


def cut_region(
    region: Sequence[Rect], vertical: bool, share: float,
) -> tuple[list[Rect], list[Rect]]:
    """`region` cut by one straight line into a first part (left or below) holding
    `share` of its area, and the rest."""
    if len(region) == 1:
        x0, y0, x1, y1 = region[0]
        if vertical:
            x = x0 + (x1 - x0) * share
            return [(x0, y0, x, y1)], [(x, y0, x1, y1)]
        y = y0 + (y1 - y0) * share
        return [(x0, y0, x1, y)], [(x0, y, x1, y1)]
    lo, hi, a, b = (0, 2, 1, 3) if vertical else (1, 3, 0, 2)
    want = share * sum((r[2] - r[0]) * (r[3] - r[1]) for r in region)
    stops = sorted({r[lo] for r in region} | {r[hi] for r in region})
    line, reached = stops[-1], 0.0
    for s, t in itertools.pairwise(stops):
        height = sum(r[b] - r[a] for r in region if r[lo] <= s and r[hi] >= t)
        if reached + height * (t - s) >= want:
            line = s + (want - reached) / height if height > 0 else s
            break
        reached += height * (t - s)
    first: list[Rect] = []
    second: list[Rect] = []
    for r in region:
        if r[lo] < line - EPS:
            first.append((r[0], r[1], min(r[2], line), r[3]) if vertical
                         else (r[0], r[1], r[2], min(r[3], line)))
        if r[hi] > line + EPS:
            second.append((max(r[0], line), r[1], r[2], r[3]) if vertical
                          else (r[0], max(r[1], line), r[2], r[3]))
    return first, second


def _asked(brief: Brief, state: State, shaped: Sequence[int]) -> list[float]:
    """The area each room asks of the tree. A rectangle asks its target's area (times
    its share); the L and T rooms share what the rectangles leave, as in a real plan,
    where an L's area falls short of its bounding box by whatever its neighbours need.
    When the rectangles leave too little for that, every room is scaled alike.
    `shaped`: the rooms that are Ls or Ts."""
    asked = [needs.area * share for needs, share in zip(brief.needs, state.share, strict=True)]
    if shaped:
        rest = brief.area - sum(state.holes) - sum(asked) + sum(asked[r] for r in shaped)
        wanted = sum(asked[r] for r in shaped)
        if rest > L_LEAST * wanted:
            for r in shaped:
                asked[r] *= rest / wanted
    return asked


def room_rects(brief: Brief, state: State, parts: list[list[Rect]] | None = None
               ) -> list[list[Rect]]:
    """Each room's rectangles under the tree, then each void's; into `parts`, when
    given, each room's rectangles before the outline cut them."""
    n = len(brief.ids)
    tokens = state.tokens
    weight = [0.0] * len(tokens)
    left = [0] * len(tokens)
    right = [0] * len(tokens)
    stack: list[int] = []
    shaped = [t - n for t in tokens if n <= t < 2 * n]
    asked = _asked(brief, state, shaped)
    present = set(shaped)
    for p, t in enumerate(tokens):
        if t >= 2 * n:  # a part of the box outside the outline
            k = t - 2 * n
            if k < len(brief.voids):
                x0, y0, x1, y1 = brief.voids[k]
                weight[p] = (x1 - x0) * (y1 - y0)
            else:
                weight[p] = state.holes[k - len(brief.voids)]
        elif t >= 0:
            room = t % n
            part = 1.0
            if room in present:
                part = state.split[room] if t < n else 1.0 - state.split[room]
            weight[p] = asked[room] * part
        else:
            right[p] = stack.pop()
            left[p] = stack.pop()
            weight[p] = weight[left[p]] + weight[right[p]]
        stack.append(p)
    fillers = brief.fillers.count if brief.fillers else 0
    rooms: list[list[Rect]] = [[] for _ in range(n + len(brief.voids) + fillers)]
    todo: list[tuple[int, Sequence[Rect]]] = [(len(tokens) - 1, brief.floor)]
    while todo:
        p, region = todo.pop()
        t = tokens[p]
        if t >= 2 * n:
            rooms[t - n].extend(region)
            continue
        if t >= 0:
            rooms[t % n].extend(clipped(region, brief.outside) if brief.outside else region)
            if parts is not None:
                parts[t % n].extend(region)
            continue
        first, second = cut_region(region, t == VERTICAL, weight[left[p]] / weight[p])
        todo.append((left[p], first))
        todo.append((right[p], second))
    return rooms


def clipped(rects: Sequence[Rect], outside: Sequence[Rect]) -> list[Rect]:
    """`rects` less the `outside` rectangles (each cut into at most four pieces)."""
    out = list(rects)
    for ox0, oy0, ox1, oy1 in outside:
        kept: list[Rect] = []
        for r in out:
            x0, y0, x1, y1 = r
            if ox0 >= x1 - EPS or ox1 <= x0 + EPS or oy0 >= y1 - EPS or oy1 <= y0 + EPS:
                kept.append(r)
                continue
            if oy0 > y0 + EPS:
                kept.append((x0, y0, x1, oy0))
            if oy1 < y1 - EPS:
                kept.append((x0, oy1, x1, y1))
            low, high = max(y0, oy0), min(y1, oy1)
            if ox0 > x0 + EPS:
                kept.append((x0, low, ox0, high))
            if ox1 < x1 - EPS:
                kept.append((ox1, low, x1, high))
        out = kept
    return out


def merged(rects: list[Rect]) -> list[Rect]:
    """Rectangles sharing a whole side made one (the parts of an outline's piece)."""
    rects = [r for r in rects if r[2] - r[0] > EPS and r[3] - r[1] > EPS]
    merging = True
    while merging and len(rects) > 1:
        merging = False
        for i in range(len(rects)):
            for j in range(i + 1, len(rects)):
                a, b = rects[i], rects[j]
                if abs(a[0] - b[0]) < EPS and abs(a[2] - b[2]) < EPS and (
                        abs(a[3] - b[1]) < EPS or abs(b[3] - a[1]) < EPS):
                    rects[i] = (a[0], min(a[1], b[1]), a[2], max(a[3], b[3]))
                elif abs(a[1] - b[1]) < EPS and abs(a[3] - b[3]) < EPS and (
                        abs(a[2] - b[0]) < EPS or abs(b[2] - a[0]) < EPS):
                    rects[i] = (min(a[0], b[0]), a[1], max(a[2], b[2]), a[3])
                else:
                    continue
                del rects[j]
                merging = True
                break
            if merging:
                break
    return rects


def from_tiling(brief: Brief, fit: Tiling) -> State:
    """The tree of an exact tiling, each L room asking the area its parts have."""
    n = len(brief.ids)
    holes = [fit.parts[leaf][0] * fit.parts[leaf][1] for leaf in sorted(fit.parts)
             if leaf >= 2 * n]
    state = State(list(fit.tokens), [1.0] * n, [0.5] * n, holes)
    for r in fit.shaped:
        (wa, da), (wb, db) = fit.parts[r], fit.parts[n + r]
        state.share[r] = (wa * da + wb * db) / brief.needs[r].area
        state.split[r] = wa * da / (wa * da + wb * db)
    return state


def layout_of(brief: Brief, state: State) -> dict[str, list[Box]]:
    rooms = room_rects(brief, state)
    return {room_id: [Box(*r) for r in merged(rects)]
            for room_id, rects in zip(brief.ids, rooms, strict=False)}
