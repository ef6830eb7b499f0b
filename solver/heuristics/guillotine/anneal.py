"""The guillotine search's annealing over slicing trees (`anneal`), and the polish of
a valid layout's areas by coordinate descent (`polished`)."""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable

from floorplan.solver.heuristics.guillotine.brief import EPS, Brief, State
from floorplan.solver.heuristics.guillotine.moves import (
    KEEPING_WEIGHTS,
    SHARE_RANGE,
    SPLIT_RANGE,
    clamped,
    moved,
)
from floorplan.solver.heuristics.guillotine.score import score_state

#: The temperature falls from the typical first move's change to this share of it.
COOLING = 1e-3
#: Relative steps of the polish of a layout's areas (`polished`), and the scores it
#: may spend on one layout (each about 0.05 ms; 260-370 on a 10-room plan).
POLISH_STEPS = (0.05, 0.01, 0.002)
POLISH_SCORES = 1500


def anneal(
    brief: Brief, state: State, rng: random.Random, steps: int, deadline: float | None,
    should_stop: Callable[[], bool] | None, *, heat: float | None = None,
) -> tuple[State, float, int, int]:
    """Anneal from `state` for `steps` steps; the best state that breaks nothing (or,
    if none, the lowest), its energy, its broken count and the steps taken."""
    energy, broken = score_state(brief, state)
    best = (state, energy, broken)
    deltas = []
    for _ in range(20):
        other = moved(brief, state, rng)
        if other is not None:
            deltas.append(abs(score_state(brief, other)[0] - energy))
    hot = heat if heat is not None else max(
        1.0, sorted(deltas)[len(deltas) // 2] if deltas else 1.0)
    cold = hot * COOLING
    step = 0
    for step in range(1, steps + 1):
        if step % 256 == 0 and ((deadline is not None and time.monotonic() > deadline)
                                or (should_stop is not None and should_stop())):
            break
        other = moved(brief, state, rng, KEEPING_WEIGHTS if heat is not None else ())
        if other is None:
            continue
        temperature = hot * (cold / hot) ** (step / steps)
        e, b = score_state(brief, other)
        if e <= energy or rng.random() < math.exp((energy - e) / temperature):
            state, energy, broken = other, e, b
            if (broken, energy) < (best[2], best[1]):
                best = (state, energy, broken)
                if broken == 0 and energy <= EPS:
                    break  # every room at its target, nothing broken: the least energy
    return best[0], best[1], best[2], step


def polished(brief: Brief, state: State, energy: float, deadline: float | None
             ) -> tuple[State, float]:
    """`state` (breaking nothing) with its rooms' areas and its Ls' splits set by
    coordinate descent, each change kept when it lowers the energy and breaks nothing:
    the annealing changes them by random factors, and even at its coldest ends a few
    per cent off a layout whose rectangles all meet their targets (bench/NOTES.md,
    'Polishing the guillotine search's areas'). Every rectangle at
    its target's area is tried first, then each room's area and split by ever smaller
    steps, within `POLISH_SCORES` scores."""
    n = len(brief.ids)
    scores = 0

    def better(candidate: State) -> bool:
        nonlocal state, energy, scores
        scores += 1
        e, b = score_state(brief, candidate)
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
                    candidate.share[room] = clamped(state.share[room] * factor, SHARE_RANGE)
                    if better(candidate):
                        improved = True
                        break
                if room in shaped:
                    for delta in (step, -step):
                        candidate = state.copy()
                        candidate.split[room] = clamped(state.split[room] + delta, SPLIT_RANGE)
                        if better(candidate):
                            improved = True
                            break
    return state, energy
