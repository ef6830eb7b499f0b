"""Whole-floor layouts by guillotine cuts, with L- and T-shaped rooms (issue 19).

Real plans are drawn wall by wall: the floor is cut in two, each part again, until
every room has its part, and a room that is an L or a T owns two neighbouring parts.
This search works in that space. A layout is a slicing tree (a Polish expression, as
in Wong and Liu's floorplanning) whose leaves are the rooms, plus a second leaf for each
room that is an L or a T. Every cut divides its region in proportion to the areas asked
of its two sides, so each room gets the area asked of it and the floor is covered by
construction; what the annealing chooses is the order of the cuts, their directions,
which rooms have a second leaf, how such a room shares its area between its two parts,
and how much area each room asks for.

The score is E_size (Eq. 6) on bounding boxes, the relative area error and a small
price per extra rectangle, plus every hard constraint a room can break (C_size Eq. 5,
C_ratio Eq. 7, C_pos Eq. 8, C_boundary Eq. 9, C_adj Eq. 10, a connected shape within
its rectangle cap and arms wide enough) priced by its shortfall. Only layouts that break
none are kept, and the caller's checker has the last word.

The annealing starts, cool, from the exact tilings of the floor by the targets where
there are any (solver/heuristics/tiling.py), on three models of the floor; from random
trees it reaches about three times the plan's score at best (bench/NOTES.md), so it
starts from those only for small floors.

Why: the MIQP's first layout fixes which room lies next to which, and everything after
it (the hierarchy, the reshaping) moves walls locally; an annealing over slicing trees
changes that topology globally, and a plan drawn as real ones are is one of its states.
"""

from __future__ import annotations

import itertools
import math
import random
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

from floorplan.models import Problem
from floorplan.solver.geometry import Box, Domain, edges_named, rectangles_of
from floorplan.solver.heuristics.level_one import shape_allowance
from floorplan.solver.heuristics.tiling import TOL as SIDE_TOL
from floorplan.solver.heuristics.tiling import Fillers, Tiling, tilings

#: (x0, y0, x1, y1): the search's own rectangles, plain tuples for speed.
Rect = tuple[float, float, float, float]

#: The operators of the Polish expression: a vertical cut (left part | right part) and
#: a horizontal one (lower part / upper part). Leaves are numbers >= 0.
VERTICAL, HORIZONTAL = -1, -2

#: Lengths closer than this (m) are equal.
EPS = 1e-7
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
#: A part of an L narrower than this (m) is a broken shape: below half a metre a part
#: is no use as floor. What the outline cuts off a part may be thinner (the plans have
#: strips of 5-45 cm where a room's cell crossed a notch's corner: the outline's doing,
#: not the search's).
MIN_ARM = 0.5
#: Annealing steps per room, split between `RESTARTS` independent runs (the best kept).
STEPS_PER_ROOM = 2500
RESTARTS = 3
#: The temperature falls from the typical first move's change to this share of it.
COOLING = 1e-3
#: Exact tilings sought in each model of the floor; the annealing starts from the
#: `STARTS` that break the least, at `SEEDED_HEAT`: cool, so that what fits stays.
#: (Sixty tilings and the best four of them did worse: what breaks least at first is
#: not what mends best.)
TILINGS = 6
STARTS = 6
#: Scores the search over the halves of a tiling's cuts may spend on one tiling (each
#: about 0.1 ms): every way when that is few enough.
MIRROR_SCORES = 256
SEEDED_HEAT = 1.0
#: At most this share of the rooms (and at least one) may be Ls at once.
L_SHARE = 0.34
#: The L and T rooms take the floor the rectangles leave while it is at least this share
#: of their targets' area.
L_LEAST = 0.4
#: The annealing's moves and how often each is drawn.
_MOVES = ("swap", "neighbours", "turn", "shift", "regraft", "transpose", "mirror", "twins",
          "shape", "area")
MOVE_WEIGHTS = (0.1, 0.1, 0.1, 0.1, 0.2, 0.05, 0.05, 0.0, 0.12, 0.18)
#: From an exact tiling, mostly the moves that keep it: a group mirrored, two rooms
#: of one size swapped.
KEEPING_WEIGHTS = (0.02, 0.02, 0.02, 0.02, 0.04, 0.02, 0.6, 0.2, 0.02, 0.04)
#: Rooms up to which the annealing starts from random trees: beyond, it finds a valid
#: layout too rarely in the time it has (measured on the planted briefs,
#: bench/NOTES.md). Up to `MAX_TILED_ROOMS`, it starts only from exact tilings.
MAX_ROOMS = 10
MAX_TILED_ROOMS = 16
#: At most this many cells of a plan cut from the outline's bounding box may lie wholly
#: outside the outline (briefs with two or three such cells were those the search
#: found no tiling for, bench/NOTES.md).
FILLERS = 2
#: A room asks for this share of its target's area at least and at most; an L's first
#: part holds this share of its area at least and at most (the annealing's moves and
#: the polish keep to both).
SHARE_RANGE = (0.4, 1.3)
SPLIT_RANGE = (0.1, 0.9)
#: Relative steps of the polish of a layout's areas (`_polished`), and the scores it
#: may spend on one layout (each about 0.05 ms; 260-370 on a 10-room plan).
POLISH_STEPS = (0.05, 0.01, 0.002)
POLISH_SCORES = 1500
#: Share of the search's time the exact tilings may take.
TILING_SHARE = 0.4
#: The annealing runs from the tilings again while at least this many seconds are left
#: before the deadline and none of its runs gave a layout.
AGAIN_SECONDS = 0.1


@dataclass(frozen=True)
class _Needs:
    """What one room asks for, in the search's plain numbers."""

    target: tuple[float, float]
    area: float
    lo: tuple[float, float]
    hi: tuple[float, float]
    ratio: tuple[float, float] | None
    points: tuple[tuple[float, float], ...]
    #: The outline edges the room must run along (C_boundary): (facing, line, lo, hi).
    edges: tuple[tuple[str, float, float, float], ...]
    cap: int
    arm: float


@dataclass(frozen=True)
class _Brief:
    ids: tuple[str, ...]
    needs: tuple[_Needs, ...]
    #: (room, partners, min_contact) per adjacency (C_adj).
    adjacency: tuple[tuple[int, tuple[int, ...], float], ...]
    floor: tuple[Rect, ...]
    area: float
    #: The parts of `floor` outside the outline, as leaves n + n + k of the tree that no
    #: room takes: a cut plan of the outline's bounding box, the notches among its parts.
    voids: tuple[Rect, ...] = ()
    #: The parts of `floor` outside the outline that rooms lose after the cuts (a plan
    #: cut from a rectangle, then to its outline) ...
    outside: tuple[Rect, ...] = ()
    #: ... and leaves after the voids that no room takes, of the sizes the state says,
    #: which must fall outside the outline (cells of such a plan left outside it).
    fillers: Fillers | None = None


@dataclass
class _State:
    """One slicing tree. Leaf r < n is room r's part; leaf n + r its second part, present
    while room r is an L or a T."""

    tokens: list[int]
    #: Each room's area relative to its target's.
    share: list[float]
    #: An L room's first part's share of its area.
    split: list[float]
    #: The fillers' areas.
    holes: list[float] = field(default_factory=list)

    def copy(self) -> _State:
        return _State(self.tokens[:], self.share[:], self.split[:], self.holes[:])


@dataclass(frozen=True)
class GuillotineResult:
    """The best layout found that breaks nothing: room id -> rectangles, its score."""

    rooms: dict[str, list[Box]]
    energy: float
    steps: int


def applies(problem: Problem, domain: Domain) -> bool:
    """Whether the search can lay this floor out: rooms with targets, no obstacles,
    regions or fixed rooms, and not too many rooms."""
    return (0 < len(problem.rooms) <= MAX_TILED_ROOMS and not problem.obstacles
            and not problem.regions and not domain.notches
            and all(r.target_size is not None and r.fixed is None for r in problem.rooms))


def guillotine_layout(
    problem: Problem, domain: Domain, *, seed: int, deadline: float | None = None,
    should_stop: Callable[[], bool] | None = None, steps: int | None = None,
    accept: Callable[[dict[str, list[Box]]], bool] | None = None,
    tiled: bool = True, untiled: bool = True,
) -> GuillotineResult | None:
    """The best layout of `problem` the annealing over slicing trees finds that breaks
    no hard constraint by its own reckoning and that `accept` (the checker, given by the
    caller) takes, or None. Counts steps, not seconds, so a seed gives one result;
    `deadline` (monotonic) and `should_stop` cut it short. Without `tiled` no exact
    tiling is sought; without `untiled` the annealing never starts from random trees."""
    if not applies(problem, domain):
        return None
    brief = _brief(problem, domain)
    n = len(brief.ids)
    total = steps if steps is not None else STEPS_PER_ROOM * n
    rng = random.Random(seed)
    # Exact tilings by the targets first, if there are any: the annealing then starts
    # from each, cool, to meet the doors, walls and guide points keeping the fit. They
    # are sought on the outline's bounding box first, cut to the outline or with its
    # notches as voids (rooms cross the lines between the outline's rectangles in a plan
    # cut from a rectangle, as most are), then on the outline's own rectangles.
    models = [*reversed(_boxed_models(brief, domain)), brief] if tiled else []
    fits: list[tuple[_Brief, Tiling]] = []
    tiling_end = (math.inf if deadline is None
                  else time.monotonic() + TILING_SHARE * max(0.0, deadline - time.monotonic()))
    for k, model in enumerate(models):
        end = min(tiling_end,
                  time.monotonic() + (tiling_end - time.monotonic()) / (len(models) - k))
        fits += [(model, fit) for fit in tilings(
            [needs.target for needs in model.needs], model.floor, voids=model.voids,
            fillers=model.fillers, limit=TILINGS, deadline=end,
            allowed=[needs.cap >= 2 for needs in model.needs])]
    # Tilings differ in where the doors, walls and guide points land, which the halves
    # of their cuts decide: the annealing starts from those that, so turned, break the
    # least.
    turned = [(*_mirrored(model, _from_tiling(model, fit), rng, deadline), model)
              for model, fit in fits]
    seeded = sorted(turned, key=lambda start: start[0])[:STARTS]
    starts: list[tuple[_Brief, _State | None, float | None]] = [
        (model, state, SEEDED_HEAT) for _, state, model in seeded]
    if not starts and (n > MAX_ROOMS or not untiled):
        return None  # from a random tree, the annealing seldom ends valid at this size
    starts += [(brief, None, None)] * (RESTARTS if not starts else 0)
    done = 0
    while True:
        kept: list[tuple[float, _Brief, _State]] = []
        cut_short = False
        for model, start, heat in starts:
            # From a tiling, a short cool run mends it or seldom does: each gets an equal
            # share of all `STARTS`, so that the later ones still run when the first fail.
            run_steps = total // (len(starts) if start is None else max(len(starts), STARTS))
            state, energy, broken, used = _anneal(
                model, start if start is not None else _initial(model, rng), rng, run_steps,
                deadline, should_stop, heat=heat)
            done += used
            if broken == 0:
                state, energy = _polished(model, state, energy, deadline)
                kept.append((energy, model, state))
            if used < run_steps:
                cut_short = True
                break
        for energy, model, state in sorted(kept, key=lambda k: k[0]):
            rooms = _output(model, state)
            if accept is None or accept(rooms):
                return GuillotineResult(rooms, energy, done)
        # The tilings again while time is left: whether a cool run mends a tiling is
        # the luck of its moves, and another run from the same starts often does what
        # this one did not (planted-09-1017: one seed in four mends none of them).
        if (cut_short or steps is not None or deadline is None or not seeded
                or time.monotonic() > deadline - AGAIN_SECONDS):
            return None


def _brief(problem: Problem, domain: Domain) -> _Brief:
    """The problem in the search's numbers, the floor as the outline's rectangles."""
    index = {r.id: k for k, r in enumerate(problem.rooms)}
    needs = []
    for room in problem.rooms:
        assert room.target_size is not None
        tw, td = room.target_size
        edges = tuple((e.facing, e.line, *e.span)
                      for e in edges_named(problem, domain.edges, room.boundary))
        lo = room.min_size or (0.0, 0.0)
        hi = room.max_size or (math.inf, math.inf)
        needs.append(_Needs((tw, td), tw * td, (lo[0], lo[1]), (hi[0], hi[1]),
                            room.aspect_ratio, tuple(room.positions), edges,
                            shape_allowance(room), min(MIN_ARM, min(lo) or MIN_ARM)))
    adjacency = tuple((index[a.a], tuple(index[b] for b in a.partners if b in index),
                       a.min_contact) for a in problem.adjacency if a.a in index)
    floor = tuple((b.x0, b.y0, b.x1, b.y1) for b in rectangles_of(domain.free))
    return _Brief(tuple(index), tuple(needs), adjacency, floor, float(domain.free.area))


def _boxed_models(brief: _Brief, domain: Domain) -> list[_Brief]:
    """For an outline that is not a rectangle, `brief` with the floor as its bounding
    box: the parts outside the outline as voids, and the box cut as a plan drawn on a
    rectangle and then cut to its outline (the rooms lose what lies outside it, one
    fillers stand for the cells left wholly outside). None for a rectangle's."""
    box = domain.bbox
    beyond = box.to_polygon().difference(domain.free)
    outside = tuple((b.x0, b.y0, b.x1, b.y1) for b in rectangles_of(beyond))
    if not outside:
        return []
    parts = [part.bounds for part in getattr(beyond, "geoms", [beyond])]
    fillers = Fillers(FILLERS, (max(p[2] - p[0] for p in parts), max(p[3] - p[1] for p in parts)),
                      beyond.area, tuple((p[2] - p[0], p[3] - p[1]) for p in parts))
    whole = ((box.x0, box.y0, box.x1, box.y1),)
    return [replace(brief, floor=whole, voids=outside),
            replace(brief, floor=whole, area=box.area, outside=outside, fillers=fillers)]


# --- the slicing tree -------------------------------------------------------------


def _initial(brief: _Brief, rng: random.Random) -> _State:
    """A random balanced tree over the rooms, each a rectangle asking its target area."""
    n = len(brief.ids)
    order = list(range(n))
    rng.shuffle(order)

    def build(rooms: list[int]) -> list[int]:
        if len(rooms) == 1:
            return rooms
        half = len(rooms) // 2
        return build(rooms[:half]) + build(rooms[half:]) + [rng.choice((VERTICAL, HORIZONTAL))]

    return _State(build(order), [1.0] * n, [0.5] * n)


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


def _asked(brief: _Brief, state: _State, shaped: Sequence[int]) -> list[float]:
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


def _rooms(brief: _Brief, state: _State, parts: list[list[Rect]] | None = None
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
            rooms[t % n].extend(_clipped(region, brief.outside) if brief.outside else region)
            if parts is not None:
                parts[t % n].extend(region)
            continue
        first, second = cut_region(region, t == VERTICAL, weight[left[p]] / weight[p])
        todo.append((left[p], first))
        todo.append((right[p], second))
    return rooms


def _clipped(rects: Sequence[Rect], outside: Sequence[Rect]) -> list[Rect]:
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


# --- the score ----------------------------------------------------------------------


def _merged(rects: list[Rect]) -> list[Rect]:
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


def _scored(brief: _Brief, state: _State) -> tuple[float, int]:
    """`_score` of the layout under `state`."""
    if not brief.outside:  # nothing cut: the rooms are the tree's own parts
        rooms = _rooms(brief, state)
        return _score(brief, rooms, rooms)
    parts: list[list[Rect]] = [[] for _ in brief.ids]
    return _score(brief, _rooms(brief, state, parts), parts)


def _score(brief: _Brief, rooms: list[list[Rect]], parts: list[list[Rect]]
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
        inside = sum((r[2] - r[0]) * (r[3] - r[1]) for r in _clipped(rects, brief.outside))
        if inside > EPS:
            broken += 1
            shortfall += inside
    for needs, rects, own in zip(brief.needs, rooms, parts, strict=False):
        rects = _merged(rects) if len(rects) > 1 else rects
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
                made = _merged(own)
                wall = min(needs.arm, *(_thickness(r) for r in rects))
            elif brief.voids:
                # A part touching a void (a notch) may be as thin as the notch leaves
                # it, as a part the outline cut may in the other model (planted-10-6726:
                # a 0.3 m step over the notch's corner).
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


# --- the annealing ------------------------------------------------------------------


def _valid_postfix(tokens: list[int]) -> bool:
    depth = 0
    for t in tokens:
        depth += 1 if t >= 0 else -1
        if depth < 1:
            return False
    return depth == 1


def _same_size(brief: _Brief, a: int, b: int) -> bool:
    (wa, da), (wb, db) = brief.needs[a].target, brief.needs[b].target
    return abs(wa - wb) < SIDE_TOL and abs(da - db) < SIDE_TOL


def _moved(brief: _Brief, state: _State, rng: random.Random,
           weights: Sequence[float] = ()) -> _State | None:
    """One random change of the tree, or None when the drawn change cannot be made."""
    n = len(brief.ids)
    new = state.copy()
    tokens = new.tokens
    kind = rng.choices(_MOVES, weights or MOVE_WEIGHTS)[0]
    if len(tokens) < 3 and kind not in ("shape", "area"):
        return None  # a single part: nothing to swap, turn or move
    if kind == "swap":  # two parts change places
        p, q = rng.sample([p for p, t in enumerate(tokens) if t >= 0], 2)
        tokens[p], tokens[q] = tokens[q], tokens[p]
    elif kind == "neighbours":  # two parts next to each other in the tree change places
        leaves = [p for p, t in enumerate(tokens) if t >= 0]
        k = rng.randrange(len(leaves) - 1)
        p, q = leaves[k], leaves[k + 1]
        tokens[p], tokens[q] = tokens[q], tokens[p]
    elif kind == "turn":  # a cut turns
        p = rng.choice([p for p, t in enumerate(tokens) if t < 0])
        tokens[p] = VERTICAL if tokens[p] == HORIZONTAL else HORIZONTAL
    elif kind == "shift":  # a part moves past a cut (changes the tree's shape)
        p = rng.randrange(len(tokens) - 1)
        if (tokens[p] >= 0) == (tokens[p + 1] >= 0):
            return None
        tokens[p], tokens[p + 1] = tokens[p + 1], tokens[p]
        if not _valid_postfix(tokens):
            return None
    elif kind == "regraft":  # a group of rooms moves elsewhere, whole
        if not _regrafted(tokens, rng):
            return None
    elif kind in ("transpose", "mirror"):  # a group turns a quarter, or its halves swap
        if len(tokens) < 3:
            return None
        starts = _starts(tokens)
        p = rng.choice([p for p, t in enumerate(tokens) if t < 0])
        if kind == "transpose":
            tokens[starts[p]:p] = [t if t >= 0 else VERTICAL + HORIZONTAL - t
                                   for t in tokens[starts[p]:p]]
            tokens[p] = VERTICAL + HORIZONTAL - tokens[p]
        else:
            right = starts[p - 1]
            tokens[starts[p]:p] = tokens[right:p] + tokens[starts[p]:right]
    elif kind == "twins":  # two rooms of the same size change places
        shaped = {u - n for u in tokens if n <= u < 2 * n}
        n_leaves = [p for p, t in enumerate(tokens) if 0 <= t < n and t not in shaped]
        if len(n_leaves) < 2:
            return None
        p = rng.choice(n_leaves)
        same = [q for q in n_leaves if q != p and _same_size(brief, tokens[p], tokens[q])]
        if not same:
            return None
        q = rng.choice(same)
        tokens[p], tokens[q] = tokens[q], tokens[p]
    elif kind == "shape":  # a room becomes an L or a rectangle again
        present = [t for t in tokens if n <= t < 2 * n]
        if present and (rng.random() < 0.5 or len(present) >= max(1, round(L_SHARE * n))):
            _drop_leaf(tokens, tokens.index(rng.choice(present)))
        else:
            room = rng.randrange(n)
            if n + room in tokens or brief.needs[room].cap < 2:
                return None
            at = (tokens.index(room) if rng.random() < 0.5
                  else rng.choice([p for p, t in enumerate(tokens) if t >= 0]))
            pair = [tokens[at], n + room] if rng.random() < 0.5 else [n + room, tokens[at]]
            tokens[at:at + 1] = [*pair, rng.choice((VERTICAL, HORIZONTAL))]
            new.split[room] = rng.uniform(0.35, 0.75)
            new.share[room] = min(new.share[room], rng.uniform(0.65, 0.9))
    else:  # a room asks for more or less area, or an L shares it otherwise
        room = rng.randrange(n)
        if n + room in tokens and rng.random() < 0.5:
            new.split[room] = _clamped(new.split[room] + rng.gauss(0.0, 0.1), SPLIT_RANGE)
        else:
            new.share[room] = _clamped(new.share[room] * math.exp(rng.gauss(0.0, 0.06)),
                                       SHARE_RANGE)
    return new


def _clamped(value: float, bounds: tuple[float, float]) -> float:
    return min(bounds[1], max(bounds[0], value))


def _starts(tokens: list[int]) -> list[int]:
    """Where each node's subtree starts: node p's subtree is tokens[starts[p]:p + 1]."""
    starts: list[int] = []
    stack: list[int] = []
    for p, t in enumerate(tokens):
        if t >= 0:
            starts.append(p)
        else:
            stack.pop()
            starts.append(starts[stack.pop()])
        stack.append(p)
    return starts


def _regrafted(tokens: list[int], rng: random.Random) -> bool:
    """Cut a random subtree out (its sibling takes its parent's place) and join it to a
    random node of the rest under a new cut: a group of rooms moves as it is."""
    if len(tokens) < 5:
        return False
    starts = _starts(tokens)
    top = len(tokens) - 1
    node = rng.randrange(top)  # any node but the root
    first = starts[node]
    parent = next(q for q in range(node + 1, len(tokens)) if tokens[q] < 0 and starts[q] <= first)
    group = tokens[first:node + 1]
    rest = tokens[:first] + tokens[node + 1:parent] + tokens[parent + 1:]
    starts = _starts(rest)
    anchor = rng.randrange(len(rest))
    joined = (rest[starts[anchor]:anchor + 1] + group if rng.random() < 0.5
              else group + rest[starts[anchor]:anchor + 1])
    tokens[:] = (rest[:starts[anchor]] + joined + [rng.choice((VERTICAL, HORIZONTAL))]
                 + rest[anchor + 1:])
    return True


def _drop_leaf(tokens: list[int], at: int) -> None:
    """Remove the leaf at `at` and the cut that joined it to its sibling."""
    starts = _starts(tokens)
    parent = next(q for q in range(at + 1, len(tokens)) if tokens[q] < 0 and starts[q] <= at)
    del tokens[parent]
    del tokens[at]


def _anneal(
    brief: _Brief, state: _State, rng: random.Random, steps: int, deadline: float | None,
    should_stop: Callable[[], bool] | None, *, heat: float | None = None,
) -> tuple[_State, float, int, int]:
    """Anneal from `state` for `steps` steps; the best state that breaks nothing (or,
    if none, the lowest), its energy, its broken count and the steps taken."""
    energy, broken = _scored(brief, state)
    best = (state, energy, broken)
    deltas = []
    for _ in range(20):
        other = _moved(brief, state, rng)
        if other is not None:
            deltas.append(abs(_scored(brief, other)[0] - energy))
    hot = heat if heat is not None else max(
        1.0, sorted(deltas)[len(deltas) // 2] if deltas else 1.0)
    cold = hot * COOLING
    step = 0
    for step in range(1, steps + 1):
        if step % 256 == 0 and ((deadline is not None and time.monotonic() > deadline)
                                or (should_stop is not None and should_stop())):
            break
        other = _moved(brief, state, rng, KEEPING_WEIGHTS if heat is not None else ())
        if other is None:
            continue
        temperature = hot * (cold / hot) ** (step / steps)
        e, b = _scored(brief, other)
        if e <= energy or rng.random() < math.exp((energy - e) / temperature):
            state, energy, broken = other, e, b
            if (broken, energy) < (best[2], best[1]):
                best = (state, energy, broken)
    return best[0], best[1], best[2], step


def _polished(brief: _Brief, state: _State, energy: float, deadline: float | None
              ) -> tuple[_State, float]:
    """`state` (breaking nothing) with its rooms' areas and its Ls' splits set by
    coordinate descent, each change kept when it lowers the energy and breaks nothing:
    the annealing changes them by random factors, and even at its coldest ends a few
    per cent off a layout whose rectangles all meet their targets (planted-10-5015: the
    plan's own tree with an area error of 0.043 against its 0.030). Every rectangle at
    its target's area is tried first, then each room's area and split by ever smaller
    steps, within `POLISH_SCORES` scores."""
    n = len(brief.ids)
    scores = 0

    def better(candidate: _State) -> bool:
        nonlocal state, energy, scores
        scores += 1
        e, b = _scored(brief, candidate)
        if b == 0 and e < energy - EPS:
            state, energy = candidate, e
            return True
        return False

    exact = state.copy()
    exact.share = [1.0] * n
    better(exact)
    for step in POLISH_STEPS:
        improved = True
        while improved and scores < POLISH_SCORES:
            if deadline is not None and time.monotonic() > deadline:
                return state, energy
            improved = False
            shaped = {t - n for t in state.tokens if n <= t < 2 * n}
            for room in range(n):
                for factor in (1.0 + step, 1.0 - step):
                    candidate = state.copy()
                    candidate.share[room] = _clamped(state.share[room] * factor, SHARE_RANGE)
                    if better(candidate):
                        improved = True
                        break
                if room in shaped:
                    for delta in (step, -step):
                        candidate = state.copy()
                        candidate.split[room] = _clamped(state.split[room] + delta, SPLIT_RANGE)
                        if better(candidate):
                            improved = True
                            break
    return state, energy


def _mirrored(brief: _Brief, state: _State, rng: random.Random,
              deadline: float | None) -> tuple[tuple[int, float], _State]:
    """`state` with the two halves of each cut swapped or not, as breaks least, and its
    (broken, energy): every way when there are few cuts, else by swaps that each lower
    the score, from the start and from random ways, within `MIRROR_SCORES` scores.
    Swapping halves keeps a tiling's fit; it is where the doors, walls and guide points
    are won or lost."""
    tree = _tree(state.tokens)
    cuts = sum(t < 0 for t in state.tokens)

    def scored(flips: Sequence[bool]) -> tuple[tuple[int, float], _State]:
        other = replace(state, tokens=_emit(tree, flips))
        energy, broken = _scored(brief, other)
        return (broken, energy), other

    flips = [False] * cuts
    best_key, best = scored(flips)
    if 2 ** cuts <= MIRROR_SCORES:
        for way in itertools.product((False, True), repeat=cuts):
            key, other = scored(way)
            if key < best_key:
                best_key, best = key, other
        return best_key, best
    scores = 1
    key = best_key
    while scores < MIRROR_SCORES and best_key[0] > 0:
        improved = False
        for cut in rng.sample(range(cuts), cuts):
            flips[cut] = not flips[cut]
            new_key, other = scored(flips)
            scores += 1
            if new_key < key:
                key, improved = new_key, True
                if key < best_key:
                    best_key, best = key, other
            else:
                flips[cut] = not flips[cut]
        if deadline is not None and time.monotonic() > deadline:
            break
        if not improved:  # a local best: start again from a random way
            flips = [rng.random() < 0.5 for _ in range(cuts)]
            key, _ = scored(flips)
            scores += 1
    return best_key, best


#: A slicing tree: a leaf, or (cut, its number, first half, second half).
_Node = int | tuple[int, int, "_Node", "_Node"]


def _tree(tokens: Sequence[int]) -> _Node:
    """The tree of a postfix expression, its cuts numbered in postfix order."""
    stack: list[_Node] = []
    cuts = 0
    for t in tokens:
        if t >= 0:
            stack.append(t)
        else:
            second, first = stack.pop(), stack.pop()
            stack.append((t, cuts, first, second))
            cuts += 1
    return stack[0]


def _emit(node: _Node, flips: Sequence[bool]) -> list[int]:
    """The tree in postfix, the halves of cut k swapped where flips[k]."""
    if isinstance(node, int):
        return [node]
    cut, number, first, second = node
    if flips[number]:
        first, second = second, first
    return _emit(first, flips) + _emit(second, flips) + [cut]


def _from_tiling(brief: _Brief, fit: Tiling) -> _State:
    """The tree of an exact tiling, each L room asking the area its parts have."""
    n = len(brief.ids)
    holes = [fit.parts[leaf][0] * fit.parts[leaf][1] for leaf in sorted(fit.parts)
             if leaf >= 2 * n]
    state = _State(list(fit.tokens), [1.0] * n, [0.5] * n, holes)
    for r in fit.shaped:
        (wa, da), (wb, db) = fit.parts[r], fit.parts[n + r]
        state.share[r] = (wa * da + wb * db) / brief.needs[r].area
        state.split[r] = wa * da / (wa * da + wb * db)
    return state


def _output(brief: _Brief, state: _State) -> dict[str, list[Box]]:
    rooms = _rooms(brief, state)
    return {room_id: [Box(*r) for r in _merged(rects)]
            for room_id, rects in zip(brief.ids, rooms, strict=False)}
