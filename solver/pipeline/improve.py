"""Level 1 improved (Eq. 12 under the user's own bounds): neighbourhood search with
coverage first, and a second rectangle for a room beside a gap the search cannot fill."""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from dataclasses import dataclass

from floorplan.models import ExtraRectangles
from floorplan.solver.events import Phase
from floorplan.solver.geometry import Box, Domain
from floorplan.solver.heuristics.level_one import level_one_spec, reach_wing, wing_names
from floorplan.solver.heuristics.neighbourhood import (
    GAP_AREA,
    NEIGHBOURHOOD_SIZE,
    coverage_first,
    covered_area,
    search_neighbourhoods,
)
from floorplan.solver.heuristics.variety import pull_at_random
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import Incumbent, LevelStatus, add_start
from floorplan.solver.pipeline.absorb import absorbed
from floorplan.solver.pipeline.run import Run, ScipAnswer, covered, goal_area

#: Share of the neighbourhood search spent with coverage weighted first.
COVERAGE_PHASE_SHARE = 0.85
#: A fully covering layout's polish ends after this many steps in a row without gain
#: with `options.stop: "limit"` ...
STALL_STEPS = 8
#: ... and after this many under the stall rule (`"stalled"`, the default): on planted
#: briefs the steps after the fourth without gain rarely gain, and the reshaping, which
#: gives rooms their L shapes, is better served by the time (bench/NOTES.md, "SCIP
#: decides: the stall rule and SCIP's check of the answer").
STALLED_STEPS = 4
#: Rooms given a second rectangle at level 1 to reach gaps, at most ...
GAP_WINGS = 2
#: ... for gaps larger than this (m²), trying this many rooms per gap.
GAP_WING_AREA = 0.25
WING_TRIES = 3
#: Steps without gain after which a coverage pass gives up (and a gap wing is tried).
COVER_PATIENCE = 6
#: ... or after this share of its time without gain.
COVER_STALL_SHARE = 0.2


def _cover(run: Run, domain: Domain, rects: dict[str, Box]) -> float:
    """The floor level-1 rectangles cover once gaps are absorbed, as `solve` returns it."""
    return covered(domain, absorbed(run.problem, domain, run.by_room(domain, rects)))


def _gap_wing(
    run: Run, domain: Domain, rects: dict[str, Box], deadline: float
) -> tuple[LevelModel, dict[str, Box]] | None:
    """The level-1 model with one more wing, for a room beside a gap (the largest gap
    first, the room gaining most first), and its start: the wing in the gap, the room's
    rectangle shortened where its maximum size demands (`reach_wing`). None when no room
    can take one, or no such start is feasible (a contact lost with the shortening)."""
    problem = run.problem
    if run.soft:
        return None
    gaps = sorted(domain.gaps(rects.values(), GAP_WING_AREA), key=lambda g: -g.area)
    for gap in gaps:
        candidates = []
        for name, box in rects.items():
            room = problem.room(run.room_of(name))
            if name != room.id or room.id in run.wings or room.max_rects == 1:
                continue
            reached = reach_wing(problem, domain, room, box, gap)
            if reached is not None:
                candidates.append((-reached[0], name, reached[1], reached[2]))
        for _, name, main, wing in sorted(candidates)[:WING_TRIES]:
            if time.monotonic() >= deadline - 0.1 or run.stopped():
                return None
            wings = run.wings | {name: 1}
            lm = build_level(level_one_spec(problem, domain, window=None, wings=wings))
            start = add_start(lm, rects | {name: main, wing_names(name, 1)[0]: wing})
            if start.rects is None:
                continue
            run.wings = wings
            run.extra.append(ExtraRectangles(
                room=name, rectangles=2,
                reason="a gap beside it stayed uncovered with one rectangle per room"))
            run.emit(Phase.RELAXATION, detail=f"{name} as two rectangles, to reach a gap")
            return lm, start.rects
    return None


@dataclass(frozen=True)
class _BeforeWing:
    """Level 1 as it stood before a gap wing: its model, rectangles, the floor they
    cover (gaps absorbed) and the run's wings then, to return to if the wing loses."""

    model: LevelModel
    rects: dict[str, Box]
    cover: float
    wings: dict[str, int]
    extra: list[ExtraRectangles]


def improve_level_one(
    run: Run, domain: Domain, first: dict[str, Box], deadline: float
) -> dict[str, Box]:
    """Minimise Eq. 12 under the user's own bounds from the first layout, by
    neighbourhood search on the level-1 MIQP."""
    if deadline - time.monotonic() <= 0.1 or run.stopped():
        return first
    lm = build_level(level_one_spec(run.problem, domain, window=None, wings=run.wings,
                                    soft=run.soft))
    if run.problem.options.diverse:
        pull_at_random(lm, run.problem.options.seed)
    start = add_start(lm, first)
    if start.values is None:
        return first
    assert start.rects is not None
    if len(run.problem.rooms) <= NEIGHBOURHOOD_SIZE:
        # One neighbourhood would be the whole model: solve it outright.
        def announce(inc: Incumbent) -> None:
            run.incumbent(domain, run.by_room(domain, inc.rects), inc.dual_bound)

        direct = run.run(lm, deadline - time.monotonic(), on_incumbent=announce)
        if direct.rects is None:
            return start.rects
        # The whole floor's MIQP under the user's bounds: what SCIP says of its answer
        # is what the report may say, if this layout is the one returned.
        run.scip_answer = ScipAnswer(run.by_room(domain, direct.rects),
                                     direct.status is LevelStatus.OPTIMAL,
                                     _eq12_bound(run, lm, direct.dual_bound))
        return direct.rects
    def improved(rects: dict[str, Box]) -> None:
        run.incumbent(domain, run.by_room(domain, rects))

    # Coverage first (what users judge a plan by), then the user's own weights without
    # giving coverage back. A start that covers everything skips the first phase, and
    # its search stops once it stalls: only E_size is left to gain, and the user is
    # better served by the layout now than by a few hundredths later.
    rng = random.Random(run.problem.options.seed)
    covers = covered_area(domain, start.rects) >= domain.area - GAP_AREA
    middle = time.monotonic() + (deadline - time.monotonic()) * COVERAGE_PHASE_SHARE

    rects, steps, improvements = start.rects, 0, 0
    # The search counts its own steps without gain (`STALL_STEPS`): a step takes a large
    # share of the time-based rule's window. With `options.stop: "limit"`, a search from
    # a start short of the goal polishes until its deadline.
    patient = covers or run.problem.options.stop == "stalled"
    with run.own_stall_rule():
        if not covers:
            lm, rects, steps, improvements = _coverage_passes(run, domain, lm, rects, middle,
                                                              rng, improved)
        best = search_neighbourhoods(
            lm.spec, rects, domain,
            deadline=deadline, rng=rng,
            step=lambda model, limit: run.run(model, limit), should_stop=run.ending,
            keep_coverage=True, patience=_patience(run) if patient else None,
            on_improvement=improved,
        )
    run.emit(Phase.LEVEL, objective=best.objective,
             detail=f"neighbourhood search: {improvements + best.improvements} of "
                    f"{steps + best.steps} steps improved")
    return best.rects


def _coverage_passes(
    run: Run, domain: Domain, lm: LevelModel, rects: dict[str, Box], middle: float,
    rng: random.Random, improved: Callable[[dict[str, Box]], None],
) -> tuple[LevelModel, dict[str, Box], int, int]:
    """Neighbourhood search weighted for coverage until `middle`, a gap wing at a time
    when it falls short of the goal; the model and layout it ends with, and its steps
    and improvements."""
    def good_enough(rects: dict[str, Box]) -> bool:
        return _cover(run, domain, rects) >= goal_area(domain)

    steps, improvements = 0, 0
    stall = (middle - time.monotonic()) * COVER_STALL_SHARE
    wings = 0 if not run.soft else GAP_WINGS
    unwinged: _BeforeWing | None = None
    while True:
        last = wings >= GAP_WINGS
        # Growth beyond the targets costs size error: the pass ends once the layout,
        # gaps absorbed, meets the coverage goal, or when it stalls.
        grown = search_neighbourhoods(
            coverage_first(lm.spec), rects, domain, deadline=middle, rng=rng,
            step=lambda model, limit: run.run(model, limit), should_stop=run.ending,
            on_improvement=improved, good_enough=good_enough, patience=COVER_PATIENCE,
            stall_seconds=stall,
        )
        rects, steps, improvements = (grown.rects, steps + grown.steps,
                                      improvements + grown.improvements)
        cover = _cover(run, domain, rects)
        if unwinged is not None and cover < unwinged.cover - GAP_AREA:
            # The wing's pass lost floor the layout before it covered: back to that one.
            lm, rects, run.wings, run.extra = (unwinged.model, unwinged.rects, unwinged.wings,
                                               unwinged.extra)
            break
        if (last or cover >= goal_area(domain) or time.monotonic() > middle - 0.1
                or run.stopped()):
            break
        # Short of the goal: a room beside the largest gap it can border gets a second
        # rectangle to reach in with (docs/method.md, "Gap wings"); when none can, one
        # last pass.
        unwinged = _BeforeWing(lm, rects, cover, dict(run.wings), list(run.extra))
        widened = _gap_wing(run, domain, rects, middle)
        if widened is None:
            wings, unwinged = GAP_WINGS, None
            continue
        lm, rects = widened
        wings += 1
    return lm, rects, steps, improvements


def _eq12_bound(run: Run, lm: LevelModel, dual_bound: float | None) -> float | None:
    """SCIP's dual bound of the level-1 model as a bound on Eq. 12: the model's
    objective (`spec.level_objective`) is Eq. 12 itself when every room has a target and
    is one rectangle, and nothing is added (growth term, priced slacks, sizes drawn at
    random); otherwise None."""
    spec = lm.spec
    if (dual_bound is None or spec.growth_weight or run.soft or run.problem.options.diverse
            or lm.slacks or run.wings
            or any(room.target_size is None for room in run.problem.rooms)):
        return None
    return max(dual_bound, 0.0)


def _patience(run: Run) -> int:
    """Steps in a row without gain after which the polish of a covering layout ends."""
    return STALLED_STEPS if run.problem.options.stop == "stalled" else STALL_STEPS
