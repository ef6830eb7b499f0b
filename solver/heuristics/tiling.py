"""Exact tilings of a floor by its rooms' target rectangles, as slicing trees
(docs/method.md, "Whole layouts by guillotine cuts", step 1).

A brief extracted from a real plan gives each rectangular room its exact width and
depth (its bounding box), and an L or T room its bounding box only. Such a plan is
then, very often, a guillotine tiling: rooms whose sides match join into blocks, blocks
into larger ones, until the blocks are the floor's own rectangles. This search joins
them bottom-up: two blocks may join side by side when their depths match, or stacked
when their widths do. Each block (a set of rooms and its sides) is built once, from
the blocks built before it, so the search runs over subtrees, not over the orders of
the joins around them. The two parts of an L room enter with unknown sides, each fixed
by the first block it joins and the one after. Which rooms are Ls is guessed from the
floor the targets over-ask (an L's bounding box holds some of its neighbours' floor).

A tiling is only a start: it fits the sizes, not yet the doors, walls and guide points;
the guillotine search (solver/heuristics/guillotine/) anneals from it, mostly by moves
that keep the fit (a block mirrored, two halves swapped).
"""

from __future__ import annotations

import bisect
import itertools
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

#: (x0, y0, x1, y1).
Rect = tuple[float, float, float, float]

VERTICAL, HORIZONTAL = -1, -2
#: Sides within this (m) match: briefs give sides to the centimetre.
TOL = 0.011
#: The part of an L room is at least this wide (m). The plans hold Ls with arms of 5-45
#: cm (27 of 56 planted plans measured; bench/NOTES.md, "Thin strips: the plans have
#: them, the annealing refused them"): a tiling must be able to have them; the
#: annealing then decides (solver/heuristics/guillotine/ keeps what the outline cut
#: thin and widens the rest).
MIN_PART = 0.05
#: Nodes of the search per guess of which rooms are Ls in the first round (each round
#: gives the guesses not yet searched through four times more), and in all.
FIRST_BUDGET = 20000
NODES = 4_000_000
#: An L's notch (its bounding box less its floor) is at most this share of the box.
MAX_NOTCH = 0.7


@dataclass(frozen=True)
class Tiling:
    """A slicing tree (postfix, over leaves: room r, n + r for the second part of an L
    room r, 2 n + k for void k, then the fillers), the sizes of the Ls' parts and the
    fillers (leaf -> (width, depth)) and which rooms are Ls."""

    tokens: tuple[int, ...]
    parts: dict[int, tuple[float, float]]
    shaped: frozenset[int]


@dataclass(frozen=True)
class Fillers:
    """What the parts no room takes may be, in a floor cut from the outline's bounding
    box: at most `count` of them, each no wider or deeper than `most` (the largest part of
    the box outside the outline), `area` between them at most (all of that part).
    `parts`: the sides (width, depth) of each part outside the outline; a cell may span
    one of those parts across, so each side is also offered as a filler's known side."""

    count: int
    most: tuple[float, float]
    area: float
    parts: tuple[tuple[float, float], ...] = ()


def tilings(
    targets: Sequence[tuple[float, float]], pieces: Sequence[Rect], *, limit: int,
    deadline: float, allowed: Sequence[bool] | None = None, voids: Sequence[Rect] = (),
    fillers: Fillers | None = None,
) -> list[Tiling]:
    """Up to `limit` distinct guillotine tilings of the floor (`pieces`: its rectangles)
    by rooms at their targets (width, depth), Ls among them, and by `voids` (parts of
    the pieces no room takes, as leaves 2 n + k), found by `deadline` (monotonic).
    `allowed[r]`: room r may be an L. With `fillers`, a guess may add parts of open
    size that no room takes (leaves 2 n + len(voids) + k): the cells of a plan cut from
    a rectangle that fell outside its outline."""
    floor = sum((p[2] - p[0]) * (p[3] - p[1]) for p in pieces) - sum(
        (v[2] - v[0]) * (v[3] - v[1]) for v in voids)
    over = sum(w * d for w, d in targets) - floor
    found: list[Tiling] = []
    # Guesses without fillers and with them in turn: fillers take floor, so with them
    # the Ls' notches may add up to more than the targets' surplus.
    counts = range(fillers.count + 1 if fillers else 1)
    guesses = [guess for group in itertools.zip_longest(*(
        [(shaped, count) for shaped in _guesses(
            targets, over, over + (fillers.area if count else 0.0), allowed)]
        for count in counts)) for guess in group if guess is not None]
    nodes, budget = 0, FIRST_BUDGET
    # Each guess gets a small budget, then all of them a larger one: the right guess
    # is seldom the first, and a wrong one can search long.
    while guesses and nodes < NODES and len(found) < limit:
        unfinished = []
        for shaped, count in guesses:
            if time.monotonic() > deadline or len(found) >= limit or nodes >= NODES:
                return found
            search = _Search(targets, pieces, shaped, deadline, limit - len(found), budget,
                             voids, count, fillers.most if fillers else (0.0, 0.0),
                             fillers.parts if fillers else (),
                             (over, over + (fillers.area if fillers and count else 0.0)))
            found += search.run()
            nodes += search.nodes
            if search.nodes > budget:
                unfinished.append((shaped, count))
        guesses, budget = unfinished, budget * 4
    return found


def _guesses(targets: Sequence[tuple[float, float]], least: float, most: float,
             allowed: Sequence[bool] | None) -> list[frozenset[tuple[int, bool]]]:
    """Which rooms may be the Ls, most likely first, each with the way its bar runs
    (east-west, or north-south when turned), when their notches add up to between
    `least` and `most` (m²): none when that may be nothing; else one room whose box can
    hold the notch, then two."""
    slack = TOL * 10
    if most < -slack:
        return []
    first = [frozenset[tuple[int, bool]]()] if least <= slack else []
    if most <= slack:
        return first
    n = len(targets)
    ok = [allowed is None or allowed[r] for r in range(n)]
    area = [w * d for w, d in targets]
    order = sorted(range(n), key=lambda r: -area[r])
    singles = [frozenset({(r, turned)}) for r in order for turned in (False, True)
               if ok[r] and least < MAX_NOTCH * area[r]]
    pairs = [frozenset({(a, ta), (b, tb)}) for a, b in itertools.combinations(order, 2)
             for ta in (False, True) for tb in (False, True)
             if ok[a] and ok[b] and least < MAX_NOTCH * (area[a] + area[b])]
    return first + singles + pairs


class _Search:
    """Every block the rooms of one guess can join into, each built once.

    A block is a set of leaves (a bit mask) joined into a rectangle, with its sides (in
    centimetres, which briefs give exactly) and the L parts' sides its joins fixed. A
    new block is joined with every block it shares no leaf with and whose side matches
    along the cut, so every subtree of a tiling is built once, not once per order of the
    joins around it; the floor is found when blocks holding every leaf fit its pieces."""

    def __init__(self, targets: Sequence[tuple[float, float]], pieces: Sequence[Rect],
                 shaped: frozenset[tuple[int, bool]], deadline: float, limit: int,
                 budget: int, voids: Sequence[Rect] = (), fillers: int = 0,
                 filler_most: tuple[float, float] = (0.0, 0.0),
                 filler_parts: Sequence[tuple[float, float]] = (),
                 notches: tuple[float, float] | None = None) -> None:
        self.n = n = len(targets)
        self.targets = [(_cm(w), _cm(d)) for w, d in targets]
        self.pieces = [(_cm(p[2] - p[0]), _cm(p[3] - p[1])) for p in pieces]
        self.piece_rects = list(pieces)
        self.shaped = frozenset(r for r, _ in shaped)
        self.turned = {r: turned for r, turned in shaped}
        self.deadline = deadline
        self.limit = limit
        self.budget = budget
        self.voids = [(_cm(v[2] - v[0]), _cm(v[3] - v[1])) for v in voids]
        self.filler_leaves = range(2 * n + len(voids), 2 * n + len(voids) + fillers)
        self.everything = 0
        self.nodes = 0
        self.found: list[Tiling] = []
        self.trees: set[tuple[int, ...]] = set()
        self.widest = max(w for w, _ in self.pieces)
        self.deepest = max(d for _, d in self.pieces)
        self.tol = round(TOL * 100)
        self.least = round(MIN_PART * 100) - self.tol
        self.filler_most = (_cm(filler_most[0]) + self.tol, _cm(filler_most[1]) + self.tol)
        # The Ls' notches (cm²) add up to the floor the targets over-ask, less what
        # fillers take (`notches`: least and most, m²): joins that fix them beyond it are
        # cut. The slack is what sides within `TOL` may add. Without Ls there are no
        # notches to bound: the floor over-asked is then rounding, however small.
        slack = 2 * self.tol * sum(sum(self.targets[r]) for r in self.shaped)
        self.notches = (None if notches is None or not self.shaped else
                        (notches[0] * 1e4 - slack, notches[1] * 1e4 + slack))
        # Two fillers of open sides in one row would leave two unknowns on one side (a
        # T-shaped outline's two corners; bench/NOTES.md, "Fillers with a known side,
        # one probe"): a filler spanning a part
        # outside the outline may enter with that part's side known. Not beside Ls:
        # their open sides make the search far slower there.
        self.filler_sides = sorted({(axis, _cm(side)) for part in filler_parts
                                    for axis, side in enumerate(part)}
                                   if fillers > 1 and not shaped else ())

    def run(self) -> list[Tiling]:
        n = self.n
        leaves: list[_Block] = []
        for r, (w, d) in enumerate(self.targets):
            if r in self.shaped:
                # The bar spans the room's box one way (its other side open); the arm's
                # sides are both open.
                bar = (_Block(1 << r, 0, d, _side(r, 0), None, (), (r,)) if self.turned[r]
                       else _Block(1 << r, w, 0, None, _side(r, 1), (), (r,)))
                leaves += [bar, _Block(1 << (n + r), 0, 0, _side(n + r, 0), _side(n + r, 1),
                                       (), (n + r,))]
            else:
                leaves.append(_Block(1 << r, w, d, None, None, (), (r,)))
        leaves += [_Block(1 << (2 * n + k), w, d, None, None, (), (2 * n + k,))
                   for k, (w, d) in enumerate(self.voids)]
        for leaf in self.filler_leaves:
            leaves.append(_Block(1 << leaf, 0, 0, _side(leaf, 0), _side(leaf, 1), (), (leaf,)))
            for axis, side in self.filler_sides:
                fixed = ((_side(leaf, axis), side),)
                leaves.append(_Block(1 << leaf, side, 0, None, _side(leaf, 1), fixed, (leaf,))
                              if axis == 0 else
                              _Block(1 << leaf, 0, side, _side(leaf, 0), None, fixed, (leaf,)))
        for block in leaves:
            self.everything |= block.mask
        seen: set[tuple[object, ...]] = set()
        # Blocks by their width and depth (None: open), for the joins that need a match,
        # then by their lowest leaf (a partner's must be a leaf the block lacks, which
        # skips most blocks sharing a leaf unseen), and the known sides in order, for an
        # open side's range.
        by_width: dict[int | None, dict[int, list[_Block]]] = {}
        by_depth: dict[int | None, dict[int, list[_Block]]] = {}
        widths: list[int] = []
        depths: list[int] = []
        fitting: list[list[tuple[_Block, dict[int, int]]]] = [[] for _ in self.pieces]
        stack = list(reversed(leaves))
        while stack:
            block = stack.pop()
            key = (block.mask, block.width, block.depth, block.open_width,
                   block.open_depth, block.fixed)
            # A block that fits a piece of the floor counts however often it is built:
            # each other tree of it is another tiling (the rooms otherwise grouped).
            for k, (pw, pd) in enumerate(self.pieces):
                fixed = self._fixed_by(block, pw, pd)
                if fixed is not None:
                    fitting[k].append((block, fixed))
                    self._cover(fitting, k, len(fitting[k]) - 1)
                    if len(self.found) >= self.limit:
                        return self.found
            if key in seen:
                continue
            seen.add(key)
            if time.monotonic() > self.deadline:
                self.nodes = self.budget + 1
                return self.found
            new: list[_Block] = []
            for vertical in (True, False):
                along = block.depth if vertical else block.width
                index = by_depth if vertical else by_width
                open_side = block.open_depth if vertical else block.open_width
                buckets: Iterable[dict[int, list[_Block]]]
                if open_side is None:
                    buckets = [index[k] for k in (along, None) if k in index]
                else:
                    # The partner's side fixes the open one: only sides that leave it
                    # within its part's bounds.
                    least, most = self._bounds(open_side)
                    known = depths if vertical else widths
                    first = bisect.bisect_left(known, along + least)
                    last = bisect.bisect_right(known, along + most)
                    buckets = [index[k] for k in known[first:last]]
                mask = block.mask
                partners = [other for bucket in buckets for low, group in bucket.items()
                            if not low & mask for other in group]
                for other in partners:
                    if other.mask & mask:
                        continue
                    self.nodes += 1
                    if self.nodes > self.budget:
                        return self.found
                    if self.nodes % 256 == 0 and time.monotonic() > self.deadline:
                        self.nodes = self.budget + 1
                        return self.found
                    joined = self._join(other, block, vertical)
                    if joined is not None:
                        new.append(joined)
            width = None if block.open_width is not None else block.width
            depth = None if block.open_depth is not None else block.depth
            for side, index, known in ((width, by_width, widths), (depth, by_depth, depths)):
                if side not in index and side is not None:
                    bisect.insort(known, side)
                index.setdefault(side, {}).setdefault(block.mask & -block.mask, []).append(block)
            stack += new
        return self.found

    def _join(self, a: _Block, b: _Block, vertical: bool) -> _Block | None:
        """a and b side by side (vertical cut) or stacked, or None when their shared
        sides cannot match or the block would not fit the floor."""
        # Along the cut the sides must match; across it they add.
        match_a, match_b = (a.depth, b.depth) if vertical else (a.width, b.width)
        open_a, open_b = (a.open_depth, b.open_depth) if vertical else (a.open_width, b.open_width)
        add_open_a, add_open_b = (a.open_width, b.open_width) if vertical else (
            a.open_depth, b.open_depth)
        if add_open_a is not None and add_open_b is not None:
            return None  # two unknowns on one side
        fixed = dict(a.fixed)
        fixed.update(b.fixed)
        if open_a is None and open_b is None:
            if abs(match_a - match_b) > self.tol:
                return None
            along = max(match_a, match_b)
        elif open_a is not None and open_b is not None:
            return None
        else:
            known, unknown, part = (match_b, match_a, open_a) if open_a is not None else (
                match_a, match_b, open_b)
            assert part is not None
            fixed[part] = known - unknown
            if not self._fits(part, known - unknown, fixed):
                return None
            along = known
        if a.fixed and b.fixed and not self._consistent(fixed):
            return None
        across = (a.width + b.width) if vertical else (a.depth + b.depth)
        if across > (self.widest if vertical else self.deepest) + self.tol or along > (
                self.deepest if vertical else self.widest) + self.tol:
            return None
        # The side across the cut stays open when one block's was (never both).
        open_across = add_open_a if add_open_a is not None else add_open_b
        tokens = a.tokens + b.tokens + ((VERTICAL,) if vertical else (HORIZONTAL,))
        sides = tuple(sorted(fixed.items()))
        if vertical:
            return _Block(a.mask | b.mask, across, along, open_across, None, sides, tokens)
        return _Block(a.mask | b.mask, along, across, None, open_across, sides, tokens)

    def _fixed_by(self, b: _Block, width: int, depth: int) -> dict[int, int] | None:
        """The open sides `b` leaves fixed when it is `width` x `depth`, or None when it
        cannot be."""
        fixed = dict(b.fixed)
        for known, wanted, side in ((b.width, width, b.open_width),
                                    (b.depth, depth, b.open_depth)):
            if side is None:
                if abs(known - wanted) > self.tol:
                    return None
            else:
                fixed[side] = wanted - known
                if not self._fits(side, wanted - known, fixed):
                    return None
        return fixed

    def _bounds(self, side: int) -> tuple[int, int]:
        """The least and most an open side may be (cm)."""
        leaf, axis = side >> 1, side & 1
        if leaf >= 2 * self.n:  # a filler: within the largest part outside the outline
            return self.tol + 1, self.filler_most[axis]
        return self.least, self.targets[leaf % self.n][axis] + self.tol

    def _fits(self, side: int, value: int, fixed: dict[int, int]) -> bool:
        """Whether an L part's side may be `value`: at least `MIN_PART`, within the
        room's bounding box, and its two parts still able to make that box."""
        least, most = self._bounds(side)
        leaf = side >> 1
        # A filler is a cell wholly outside the outline: no room's box to make.
        return least <= value <= most and (
            leaf >= 2 * self.n or self._consistent(fixed, leaf % self.n))

    def _consistent(self, fixed: dict[int, int], only: int | None = None) -> bool:
        """Whether each L room's parts, as far as their sides are fixed, can still make
        its box: the bar's open side and the arm's side across it add up to the box's,
        and the arm is no wider along the bar than the bar is."""
        rooms = self.shaped if only is None else (only,)
        for r in rooms:
            tw, td = self.targets[r]
            across, along = (0, 1) if self.turned[r] else (1, 0)
            box_across = (tw, td)[across]
            bar = fixed.get(_side(r, across))
            arm = fixed.get(_side(self.n + r, across))
            arm_along = fixed.get(_side(self.n + r, along))
            if bar is not None and arm is not None and abs(bar + arm - box_across) > self.tol:
                return False
            if arm_along is not None and arm_along > (tw, td)[along] + self.tol:
                return False
        return self.notches is None or self._notches_fit(fixed)

    def _notches_fit(self, fixed: dict[int, int]) -> bool:
        """Whether the notches of the Ls whose arms are fixed add up to no more than the
        floor over-asked, and, once every L's is, to no less."""
        assert self.notches is not None
        total, known = 0, 0
        for r in self.shaped:
            box = self.targets[r]
            across, along = (0, 1) if self.turned[r] else (1, 0)
            arm_along = fixed.get(_side(self.n + r, along))
            arm_across = fixed.get(_side(self.n + r, across))
            if arm_across is None and (bar := fixed.get(_side(r, across))) is not None:
                arm_across = box[across] - bar
            if arm_along is None or arm_across is None:
                continue
            total += (box[along] - arm_along) * arm_across
            known += 1
        least, most = self.notches
        return total <= most and (known < len(self.shaped) or total >= least)

    def _cover(self, fitting: list[list[tuple[_Block, dict[int, int]]]], piece: int,
               at: int) -> None:
        """Every way the blocks that fit the floor's pieces, the newest one for `piece`
        among them, hold every leaf once: each a tiling."""
        chosen: list[tuple[_Block, dict[int, int]] | None] = [None] * len(self.pieces)
        chosen[piece] = fitting[piece][at]

        def fill(k: int, mask: int, fixed: dict[int, int]) -> None:
            if len(self.found) >= self.limit:
                return
            if k == len(self.pieces):
                if mask == self.everything:
                    self._finish([c[0].tokens for c in chosen if c is not None], fixed)
                return
            options = [chosen[k]] if k == piece else fitting[k]
            for option in options:
                assert option is not None
                block, sides = option
                if block.mask & mask:
                    continue
                merged = {**fixed, **sides}
                if not self._consistent(merged):
                    continue
                chosen[k] = option
                fill(k + 1, mask | block.mask, merged)
            if k != piece:
                chosen[k] = None

        fill(0, 0, {})

    def _finish(self, trees: list[tuple[int, ...]], sides: dict[int, int]) -> None:
        n = self.n
        parts: dict[int, tuple[float, float]] = {}
        for r in self.shaped:
            tw, td = self.targets[r]
            for leaf in (r, n + r):
                w, d = sides.get(_side(leaf, 0)), sides.get(_side(leaf, 1))
                if leaf == r:  # the bar's spanning side
                    w, d = (w, td) if self.turned[r] else (tw, d)
                if w is None or d is None:
                    return
                parts[leaf] = (w / 100, d / 100)
        for leaf in self.filler_leaves:
            w, d = sides.get(_side(leaf, 0)), sides.get(_side(leaf, 1))
            if w is None or d is None:
                return
            parts[leaf] = (w / 100, d / 100)
        tokens = _floor_tree(self.piece_rects, trees)
        if tokens is not None and tokens not in self.trees:
            self.trees.add(tokens)
            self.found.append(Tiling(tokens, parts, self.shaped))


@dataclass(frozen=True, slots=True)
class _Block:
    """Joined leaves (`mask`): the known width and depth (cm), the L part side (see
    `_side`) whose unknown length adds to either (or None), the parts' sides the joins
    fixed (sorted (side, cm)) and the slicing tree in postfix (leaves >= 0)."""

    mask: int
    width: int
    depth: int
    open_width: int | None
    open_depth: int | None
    fixed: tuple[tuple[int, int], ...]
    tokens: tuple[int, ...]


def _side(leaf: int, axis: int) -> int:
    """The name of a part's width (axis 0) or depth (axis 1)."""
    return leaf * 2 + axis


def _cm(metres: float) -> int:
    return round(metres * 100)


def _floor_tree(pieces: Sequence[Rect], trees: Sequence[tuple[int, ...]]) -> tuple[int, ...] | None:
    """The pieces' trees joined by the straight lines that part the floor's pieces, as
    cuts by area would find them; None when no straight line parts them."""
    items = list(zip(pieces, trees, strict=True))

    def build(group: list[tuple[Rect, tuple[int, ...]]]) -> tuple[int, ...] | None:
        if len(group) == 1:
            return group[0][1]
        for lo, hi, op in ((0, 2, VERTICAL), (1, 3, HORIZONTAL)):
            lines = sorted({p[hi] for p, _ in group})
            for line in lines[:-1]:
                first = [g for g in group if g[0][hi] <= line + 1e-9]
                second = [g for g in group if g[0][lo] >= line - 1e-9]
                if first and second and len(first) + len(second) == len(group):
                    a, b = build(first), build(second)
                    if a is None or b is None:
                        return None
                    return a + b + (op,)
        return None

    return build(items)
