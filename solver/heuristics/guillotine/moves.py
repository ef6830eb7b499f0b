"""The guillotine search's moves: one random change of a slicing tree (`moved`: parts
swapped, cuts turned, groups of rooms moved whole, turned or mirrored, rooms of one size
swapped, rooms made Ls or rectangles again, areas and an L's split nudged), and the
surgery on postfix expressions they need."""

from __future__ import annotations

import math
import random
from collections.abc import Sequence

from floorplan.solver.heuristics.guillotine.brief import HORIZONTAL, VERTICAL, Brief, State
from floorplan.solver.heuristics.tiling import TOL as SIDE_TOL

#: At most this share of the rooms (and at least one) may be Ls at once.
L_SHARE = 0.34
#: A room asks for this share of its target's area at least and at most; an L's first
#: part holds this share of its area at least and at most (the annealing's moves and
#: the polish keep to both).
SHARE_RANGE = (0.4, 1.3)
SPLIT_RANGE = (0.1, 0.9)
#: The annealing's moves and how often each is drawn.
_MOVES = ("swap", "neighbours", "turn", "shift", "regraft", "transpose", "mirror", "twins",
          "shape", "area")
MOVE_WEIGHTS = (0.1, 0.1, 0.1, 0.1, 0.2, 0.05, 0.05, 0.0, 0.12, 0.18)
#: From an exact tiling, mostly the moves that keep it: a group mirrored, two rooms
#: of one size swapped.
KEEPING_WEIGHTS = (0.02, 0.02, 0.02, 0.02, 0.04, 0.02, 0.6, 0.2, 0.02, 0.04)


def _valid_postfix(tokens: list[int]) -> bool:
    depth = 0
    for t in tokens:
        depth += 1 if t >= 0 else -1
        if depth < 1:
            return False
    return depth == 1


def _same_size(brief: Brief, a: int, b: int) -> bool:
    (wa, da), (wb, db) = brief.needs[a].target, brief.needs[b].target
    return abs(wa - wb) < SIDE_TOL and abs(da - db) < SIDE_TOL


def moved(brief: Brief, state: State, rng: random.Random,
          weights: Sequence[float] = ()) -> State | None:
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
            new.split[room] = clamped(new.split[room] + rng.gauss(0.0, 0.1), SPLIT_RANGE)
        else:
            new.share[room] = clamped(new.share[room] * math.exp(rng.gauss(0.0, 0.06)),
                                       SHARE_RANGE)
    return new


def clamped(value: float, bounds: tuple[float, float]) -> float:
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
