"""The guillotine search itself: which floors it takes (`applies`), and
`guillotine_layout`: exact tilings sought on the floor's models, their cuts' halves
turned as breaks least, the annealing from the best of them (or, on small floors, from
random trees), each valid run polished, and the best layout the checker takes."""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable
from dataclasses import dataclass

from floorplan.models import Problem
from floorplan.solver.geometry import Box, Domain
from floorplan.solver.heuristics.guillotine.anneal import anneal, polished
from floorplan.solver.heuristics.guillotine.brief import (
    Brief,
    State,
    boxed_models,
    make_brief,
)
from floorplan.solver.heuristics.guillotine.mirror import mirrored
from floorplan.solver.heuristics.guillotine.tree import from_tiling, initial, layout_of
from floorplan.solver.heuristics.tiling import Tiling, tilings

#: Annealing steps per room, split between `RESTARTS` independent runs (the best kept).
STEPS_PER_ROOM = 2500
RESTARTS = 3
#: Exact tilings sought in each model of the floor; the annealing starts from the
#: `STARTS` that break the least, at `SEEDED_HEAT`: cool, so that what fits stays.
#: (Sixty tilings and the best four of them did worse: what breaks least at first is
#: not what mends best.)
TILINGS = 6
STARTS = 6
SEEDED_HEAT = 1.0
#: Rooms up to which the annealing starts from random trees: beyond, it finds a valid
#: layout too rarely in the time it has (measured on the planted briefs,
#: bench/NOTES.md). Up to `MAX_TILED_ROOMS`, it starts only from exact tilings.
MAX_ROOMS = 10
MAX_TILED_ROOMS = 16
#: Share of the search's time the exact tilings may take.
TILING_SHARE = 0.4
#: The annealing runs from the tilings again while at least this many seconds are left
#: before the deadline and none of its runs gave a layout.
AGAIN_SECONDS = 0.1


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
    enough: Callable[[dict[str, list[Box]]], bool] | None = None,
) -> GuillotineResult | None:
    """The best layout of `problem` the annealing over slicing trees finds that breaks
    no hard constraint by its own reckoning and that `accept` (the checker, given by the
    caller) takes, or None. Counts steps, not seconds, so a seed gives one result;
    `deadline` (monotonic) and `should_stop` cut it short. Without `tiled` no exact
    tiling is sought; without `untiled` the annealing never starts from random trees.
    A layout that breaks nothing and that `enough` takes (one no other can better, as a
    caller judges it) ends the search at once."""
    if not applies(problem, domain):
        return None
    brief = make_brief(problem, domain)
    n = len(brief.ids)
    total = steps if steps is not None else STEPS_PER_ROOM * n
    rng = random.Random(seed)
    # Exact tilings by the targets first, if there are any: the annealing then starts
    # from each, cool, to meet the doors, walls and guide points keeping the fit. They
    # are sought on the outline's bounding box first, cut to the outline or with its
    # notches as voids (rooms cross the lines between the outline's rectangles in a plan
    # cut from a rectangle, as most are), then on the outline's own rectangles.
    models = [*reversed(boxed_models(brief, domain)), brief] if tiled else []
    fits: list[tuple[Brief, Tiling]] = []
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
    turned = []
    for model, fit in fits:
        key, state = mirrored(model, from_tiling(model, fit), rng, deadline)
        if key[0] == 0 and enough is not None and enough(rooms := layout_of(model, state)):
            return GuillotineResult(rooms, key[1], 0)
        turned.append((key, state, model))
    seeded = sorted(turned, key=lambda start: start[0])[:STARTS]
    starts: list[tuple[Brief, State | None, float | None]] = [
        (model, state, SEEDED_HEAT) for _, state, model in seeded]
    if not starts and (n > MAX_ROOMS or not untiled):
        return None  # from a random tree, the annealing seldom ends valid at this size
    starts += [(brief, None, None)] * (RESTARTS if not starts else 0)
    done = 0
    while True:
        kept: list[tuple[float, Brief, State]] = []
        cut_short = False
        for model, start, heat in starts:
            # From a tiling, a short cool run mends it or seldom does: each gets an equal
            # share of all `STARTS`, so that the later ones still run when the first fail.
            run_steps = total // (len(starts) if start is None else max(len(starts), STARTS))
            state, energy, broken, used = anneal(
                model, start if start is not None else initial(model, rng), rng, run_steps,
                deadline, should_stop, heat=heat)
            done += used
            if broken == 0:
                state, energy = polished(model, state, energy, deadline)
                kept.append((energy, model, state))
                if enough is not None and enough(rooms := layout_of(model, state)):
                    return GuillotineResult(rooms, energy, done)
            if used < run_steps:
                cut_short = True
                break
        for energy, model, state in sorted(kept, key=lambda k: k[0]):
            rooms = layout_of(model, state)
            if accept is None or accept(rooms):
                return GuillotineResult(rooms, energy, done)
        # The tilings again while time is left: whether a cool run mends a tiling is
        # the luck of its moves, and another run from the same starts often does what
        # this one did not (docs/method.md, 'Whole layouts by guillotine cuts').
        if (cut_short or steps is not None or deadline is None or not seeded
                or time.monotonic() > deadline - AGAIN_SECONDS):
            return None
