"""The halves of a tiling's cuts: each cut's two halves swapped or not, as breaks least
(`mirrored`). Swapping halves keeps a tiling's fit; it is where the doors, walls and
guide points are won or lost."""

from __future__ import annotations

import itertools
import random
import time
from collections.abc import Sequence
from dataclasses import replace

from floorplan.solver.heuristics.guillotine.brief import Brief, State
from floorplan.solver.heuristics.guillotine.score import score_state

#: Scores the search over the halves of a tiling's cuts may spend on one tiling (each
#: about 0.1 ms): every way when that is few enough.
MIRROR_SCORES = 256


def mirrored(brief: Brief, state: State, rng: random.Random,
             deadline: float | None) -> tuple[tuple[int, float], State]:
    """`state` with the two halves of each cut swapped or not, as breaks least, and its
    (broken, energy): every way when there are few cuts, else by swaps that each lower
    the score, from the start and from random ways, within `MIRROR_SCORES` scores.
    Swapping halves keeps a tiling's fit; it is where the doors, walls and guide points
    are won or lost."""
    tree = _tree(state.tokens)
    cuts = sum(t < 0 for t in state.tokens)

    def scored(flips: Sequence[bool]) -> tuple[tuple[int, float], State]:
        other = replace(state, tokens=_emit(tree, flips))
        energy, broken = score_state(brief, other)
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
