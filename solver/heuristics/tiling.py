"""Exact tilings of a floor by its rooms' target rectangles (issue 19), as slicing trees.

A brief extracted from a real plan gives each rectangular room its exact width and
depth (its bounding box), and an L or T room its bounding box only. Such a plan is
then, very often, a guillotine tiling: rooms whose sides match join into blocks, blocks
into larger ones, until the blocks are the floor's own rectangles. This search joins
them bottom-up: two blocks may join side by side when their depths match, or stacked
when their widths do. The two parts of an L room enter with unknown sides, each fixed
by the first block it joins and the one after. Which rooms are Ls is guessed from the
floor the targets over-ask (an L's bounding box holds some of its neighbours' floor).

A tiling is only a start: it fits the sizes, not yet the doors, walls and guide points;
the guillotine search (solver/heuristics/guillotine.py) anneals from it, mostly by moves
that keep the fit (a block mirrored, two halves swapped).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Sequence
from dataclasses import dataclass

#: (x0, y0, x1, y1).
Rect = tuple[float, float, float, float]

VERTICAL, HORIZONTAL = -1, -2
#: Sides within this (m) match: briefs give sides to the centimetre.
TOL = 0.011
#: The part of an L room is at least this wide (m).
MIN_PART = 0.9
#: Nodes of the search per guess of which rooms are Ls in the first round (each round
#: gives the guesses not yet searched through four times more), and in all.
FIRST_BUDGET = 1500
NODES = 60000
#: An L's notch (its bounding box less its floor) is at most this share of the box.
MAX_NOTCH = 0.7


@dataclass(frozen=True)
class Block:
    """Joined rooms: its width and depth (known parts), the L part whose unknown side
    adds to either (or None), and its slicing tree in postfix (leaves >= 0)."""

    width: float
    depth: float
    #: An unknown side: (L part, its side 0 = width or 1 = depth), adding to this side.
    open_width: int | None
    open_depth: int | None
    tokens: tuple[int, ...]


@dataclass(frozen=True)
class Tiling:
    """A slicing tree (postfix, over leaves: room r, n + r for the second part of an L
    room r, 2 n + k for void k, then the fillers), the sizes of the Ls' parts and the
    fillers (leaf -> (width, depth)) and which rooms are Ls."""

    tokens: tuple[int, ...]
    parts: dict[int, tuple[float, float]]
    shaped: frozenset[int]


def tilings(
    targets: Sequence[tuple[float, float]], pieces: Sequence[Rect], *, limit: int,
    deadline: float, allowed: Sequence[bool] | None = None, voids: Sequence[Rect] = (),
    fillers: bool = False,
) -> list[Tiling]:
    """Up to `limit` distinct guillotine tilings of the floor (`pieces`: its rectangles)
    by rooms at their targets (width, depth), Ls among them, and by `voids` (parts of
    the pieces no room takes, as leaves 2 n + k), found by `deadline` (monotonic).
    `allowed[r]`: room r may be an L. With `fillers`, a guess may add one part of open
    size that no room takes (leaf 2 n + len(voids)): a cell of a plan cut from a
    rectangle that fell outside its outline."""
    floor = sum((p[2] - p[0]) * (p[3] - p[1]) for p in pieces) - sum(
        (v[2] - v[0]) * (v[3] - v[1]) for v in voids)
    over = sum(w * d for w, d in targets) - floor
    found: list[Tiling] = []
    guesses = [(shaped, 0) for shaped in _guesses(targets, over, allowed)]
    if fillers:  # a filler takes floor, so the Ls' notches may add up to more
        with_filler = [(shaped, 1) for shaped in _guesses(targets, None, allowed)]
        guesses = [g for pair in itertools.zip_longest(guesses, with_filler) for g in pair
                   if g is not None]
    nodes, budget = 0, FIRST_BUDGET
    # Each guess gets a small budget, then all of them a larger one: the right guess
    # is seldom the first, and a wrong one can search long.
    while guesses and nodes < NODES and len(found) < limit:
        unfinished = []
        for shaped, filler in guesses:
            if time.monotonic() > deadline or len(found) >= limit or nodes >= NODES:
                return found
            search = _Search(targets, pieces, shaped, deadline, limit - len(found), budget,
                             voids, filler)
            found += search.run()
            nodes += search.nodes
            if search.nodes > budget:
                unfinished.append((shaped, filler))
        guesses, budget = unfinished, budget * 4
    return found


def _guesses(targets: Sequence[tuple[float, float]], over: float | None,
             allowed: Sequence[bool] | None) -> list[frozenset[tuple[int, bool]]]:
    """Which rooms may be the Ls, most likely first, each with the way its bar runs
    (east-west, or north-south when turned): none when the targets ask for the floor
    exactly; else one room whose box can hold the surplus as its notch, then two.
    `over` None: the surplus is not known (a filler takes some floor)."""
    if over is None:
        over = 0.0
        first = [frozenset[tuple[int, bool]]()]
    elif abs(over) <= TOL * 10:
        return [frozenset()]
    elif over < 0:
        return []
    else:
        first = []
    n = len(targets)
    ok = [allowed is None or allowed[r] for r in range(n)]
    area = [w * d for w, d in targets]
    order = sorted(range(n), key=lambda r: -area[r])
    singles = [frozenset({(r, turned)}) for r in order for turned in (False, True)
               if ok[r] and over < MAX_NOTCH * area[r]]
    pairs = [frozenset({(a, ta), (b, tb)}) for a, b in itertools.combinations(order, 2)
             for ta in (False, True) for tb in (False, True)
             if ok[a] and ok[b] and over < MAX_NOTCH * (area[a] + area[b])]
    return first + singles + pairs


class _Search:
    """Depth-first joins of blocks, each state seen once."""

    def __init__(self, targets: Sequence[tuple[float, float]], pieces: Sequence[Rect],
                 shaped: frozenset[tuple[int, bool]], deadline: float, limit: int,
                 budget: int, voids: Sequence[Rect] = (), fillers: int = 0) -> None:
        self.n = len(targets)
        self.targets = targets
        self.pieces = [(p[2] - p[0], p[3] - p[1]) for p in pieces]
        self.piece_rects = list(pieces)
        self.shaped = frozenset(r for r, _ in shaped)
        self.turned = {r: turned for r, turned in shaped}
        self.deadline = deadline
        self.limit = limit
        self.budget = budget
        self.voids = [(v[2] - v[0], v[3] - v[1]) for v in voids]
        self.fillers = fillers
        self.seen: set[tuple[object, ...]] = set()
        self.nodes = 0
        self.found: list[Tiling] = []

    def run(self) -> list[Tiling]:
        blocks: list[Block] = []
        for r, (w, d) in enumerate(self.targets):
            if r in self.shaped:
                # The bar spans the room's box one way (its other side open); the arm's
                # sides are both open.
                if self.turned[r]:
                    blocks.append(Block(0.0, d, r, None, (r,)))
                else:
                    blocks.append(Block(w, 0.0, None, r + self.n * 10, (r,)))
                blocks.append(Block(0.0, 0.0, self.n + r, self.n + r + self.n * 10,
                                    (self.n + r,)))
            else:
                blocks.append(Block(w, d, None, None, (r,)))
        blocks += [Block(w, d, None, None, (2 * self.n + k,))
                   for k, (w, d) in enumerate(self.voids)]
        for k in range(self.fillers):
            leaf = 2 * self.n + len(self.voids) + k
            blocks.append(Block(0.0, 0.0, leaf, leaf + self.n * 10, (leaf,)))
        self._grow(blocks, {}, [None] * len(self.pieces))
        return self.found

    # An open side is named by its part's leaf (width) or leaf + 10 n (depth).
    def _grow(self, blocks: list[Block], sides: dict[int, float],
              claimed: list[tuple[int, ...] | None]) -> None:
        if len(self.found) >= self.limit or self.nodes > self.budget:
            return
        self.nodes += 1
        if self.nodes % 64 == 0 and time.monotonic() > self.deadline:
            self.nodes = self.budget + 1
            return
        # Sides in centimetres (None: open), which briefs give exactly.
        cm = [(None if b.open_width is not None else round(b.width * 100),
               None if b.open_depth is not None else round(b.depth * 100)) for b in blocks]
        key = (tuple(sorted((round(b.width * 100), round(b.depth * 100), b.open_width or -1,
                             b.open_depth or -1) for b in blocks)),
               tuple(c is None for c in claimed))
        if key in self.seen:
            return
        self.seen.add(key)
        if not blocks:
            if all(c is not None for c in claimed):
                self._finish(claimed, sides)
            return
        # A block the size of a free piece of the floor may take it; an open side of
        # one of its L parts is then fixed by the piece.
        for i, b in enumerate(blocks):
            if b.open_width is not None and b.open_depth is not None:
                continue
            for k, (pw, pd) in enumerate(self.pieces):
                if claimed[k] is not None:
                    continue
                fixed = self._fixed_by(b, pw, pd)
                if fixed is None:
                    continue
                taken = claimed[:]
                taken[k] = b.tokens
                self._grow(blocks[:i] + blocks[i + 1:], {**sides, **fixed}, taken)
                break
        free = [p for p, c in zip(self.pieces, claimed, strict=True) if c is None]
        if not free:
            return
        widest = max(p[0] for p in free)
        deepest = max(p[1] for p in free)
        for i, j in itertools.combinations(range(len(blocks)), 2):
            (wi, di), (wj, dj) = cm[i], cm[j]
            for vertical in (True, False):
                # Along the cut the two sides must be equal, or one of them open.
                a, b = (di, dj) if vertical else (wi, wj)
                if a is not None and b is not None and a != b:
                    continue
                joined = self._join(blocks[i], blocks[j], vertical)
                if joined is None:
                    continue
                block, fixed = joined
                if block.width > widest + TOL or block.depth > deepest + TOL or not any(
                        block.width <= pw + TOL and block.depth <= pd + TOL for pw, pd in free):
                    continue
                rest = [b for k, b in enumerate(blocks) if k not in (i, j)] + [block]
                self._grow(rest, {**sides, **fixed}, claimed)
                if len(self.found) >= self.limit or self.nodes > self.budget:
                    return

    def _join(self, a: Block, b: Block,
              vertical: bool) -> tuple[Block, dict[int, float]] | None:
        """a and b side by side (vertical cut) or stacked, or None when their shared
        sides cannot match; with the open sides the join fixes."""
        # Along the cut the sides must match; across it they add.
        match_a, match_b = (a.depth, b.depth) if vertical else (a.width, b.width)
        open_a, open_b = (a.open_depth, b.open_depth) if vertical else (a.open_width, b.open_width)
        add_open_a, add_open_b = (a.open_width, b.open_width) if vertical else (
            a.open_depth, b.open_depth)
        if add_open_a is not None and add_open_b is not None:
            return None  # two unknowns on one side
        fixed: dict[int, float] = {}
        if open_a is None and open_b is None:
            if abs(match_a - match_b) > TOL:
                return None
            along = max(match_a, match_b)
        elif open_a is not None and open_b is not None:
            return None
        else:
            known, unknown, part = (match_b, match_a, open_a) if open_a is not None else (
                match_a, match_b, open_b)
            value = known - unknown
            assert part is not None
            if not self._fits(part, value):
                return None
            fixed[part] = value
            along = known
        across = (a.width + b.width) if vertical else (a.depth + b.depth)
        # The side across the cut stays open when one block's was (never both).
        open_across = add_open_a if add_open_a is not None else add_open_b
        if vertical:
            block = Block(across, along, open_across, None, a.tokens + b.tokens + (VERTICAL,))
        else:
            block = Block(along, across, None, open_across, a.tokens + b.tokens + (HORIZONTAL,))
        return block, fixed

    def _fixed_by(self, b: Block, width: float, depth: float) -> dict[int, float] | None:
        """The open side `b` leaves fixed when it is `width` x `depth`, or None when it
        cannot be."""
        fixed: dict[int, float] = {}
        for known, wanted, side in ((b.width, width, b.open_width),
                                    (b.depth, depth, b.open_depth)):
            if side is None:
                if abs(known - wanted) > TOL:
                    return None
            elif self._fits(side, wanted - known):
                fixed[side] = wanted - known
            else:
                return None
        return fixed

    def _fits(self, side: int, value: float) -> bool:
        """Whether an L part's side may be `value`: at least `MIN_PART`, within the
        room's bounding box."""
        leaf, axis = side % (self.n * 10), side // (self.n * 10)
        if leaf >= 2 * self.n:  # a filler: any size
            return value >= MIN_PART - TOL
        room = leaf % self.n
        return MIN_PART - TOL <= value <= self.targets[room][axis] + TOL

    def _finish(self, claimed: list[tuple[int, ...] | None],
                sides: dict[int, float]) -> None:
        n = self.n
        parts: dict[int, tuple[float, float]] = {}
        for r in self.shaped:
            tw, td = self.targets[r]
            for leaf in (r, n + r):
                w, d = sides.get(leaf), sides.get(leaf + n * 10)
                if leaf == r:  # the bar's spanning side
                    w, d = (w, td) if self.turned[r] else (tw, d)
                if w is None or d is None:
                    return
                parts[leaf] = (w, d)
            (wa, da), (wb, db) = parts[r], parts[n + r]
            # The two parts' bounding box is the room's: side by side or stacked.
            if not ((abs(wa + wb - tw) <= TOL and abs(max(da, db) - td) <= TOL)
                    or (abs(da + db - td) <= TOL and abs(max(wa, wb) - tw) <= TOL)):
                return
        for k in range(self.fillers):
            leaf = 2 * n + len(self.voids) + k
            w, d = sides.get(leaf), sides.get(leaf + n * 10)
            if w is None or d is None:
                return
            parts[leaf] = (w, d)
        trees = [c for c in claimed if c is not None]
        tokens = _floor_tree(self.piece_rects, trees)
        if tokens is not None:
            self.found.append(Tiling(tokens, parts, self.shaped))


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
