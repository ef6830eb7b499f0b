"""Different plans from different seeds (batches; docs/method.md, "Different plans per
seed (batches)"): with `options.diverse`, the seed draws the sizes the search aims at,
which room starts as an L, a point for every room that the first layout is drawn
toward, and a direction for every room that the level-1 improvement leans to.

A brief usually leaves room for several arrangements, but Eq. 12 prefers one of them,
and the search finds that one from nearly every start: randomised room orders, first
layouts and ties all end in the same few plans (measured, bench/README.md#batches).
What makes a different plan by construction is a different optimum: `drawn_targets`
gives every room a target drawn within the brief's own bounds (`min_size` to
`max_size`), so each seed's search aims at another plan that the brief allows. The
draws are a Halton sequence indexed by the seed, shifted per brief: consecutive seeds
(a batch's S, S+1, ...) land far apart in the space of sizes, where independent draws
would bunch. Only the search aims there: the layout's report measures Eq. 12 against
the brief's own targets (solver/pipeline/assemble.py).

Sizes alone move walls within one arrangement; the arrangement itself (which room takes
the corner, which wall a room lies along) is the first layout's, and SCIP's first
feasible layout is much the same from seed to seed. `pull_to_anchors` gives the first
layout's models an objective, each room's centre drawn toward a point of the floor the
seed draws (an L1 distance: linear), so that the first layout found, and with it the
arrangement, follows the seed; `drawn_shape` lets one room in `L_START_CHANCE` of the
seeds start as an L (as ``shape: free`` does), whose wing takes floor a rectangle
cannot. `pull_at_random` then breaks the near-ties left in the improvement.

Measured on a 5-room flat, 100 seeds, first good layout: sizes drawn alone 45-50
distinct plans; with the anchors 48; with the anchors and an L in half the seeds 62 (in
every seed 69, at 1.6x the time); all of them valid and covering 99 %. Pulls on the
improvement, toward points or along directions, gave no more distinct plans and fewer
good ones (bench/README.md, "Batches"; bench/NOTES.md, "Batches: distinct plans by
construction, and their cost").
"""

from __future__ import annotations

import math
import random
import zlib
from collections.abc import Mapping
from functools import partial

from pyscipopt import quicksum

from floorplan.models import Problem, Room
from floorplan.solver.heuristics.level_one import may_start_as_l, started_as_l
from floorplan.solver.miqp.model import Boxes, LevelModel
from floorplan.solver.miqp.spec import free_rects

#: Weight of the random pull per metre a room's centre moves, against Eq. 12 (m²):
#: small, so that it chooses among layouts Eq. 12 finds nearly equal rather than
#: overruling coverage or sizes.
PULL_WEIGHT = 0.05
#: The drawn targets are scaled together toward the floor's area, by at most this
#: factor either way: targets far below the floor leave gaps the search must grow the
#: rooms into, at the cost of the first layouts found.
AREA_SCALE_LIMIT = 1.5
#: The drawn problem's lambda_cover is the brief's times this: sizes the seed drew may
#: be far from what fills the floor, and at the brief's own weight the optimum of a
#: draw may leave floor bare rather than move a room off its drawn size (measured: 2 of
#: 25 draws of a 5-room flat ended optimal at 97-99 % coverage).
COVER_BOOST = 1.0
#: Share of seeds in which one room (drawn among those that may have two rectangles or
#: more, and do not already start with them) starts as an L.
L_START_CHANCE = 0.5
#: Weight of the first layout's pull toward the seed's points, per metre of L1 distance
#: of a room's centre (the first layout's models have no other objective but the
#: shortfall of the size bands, m, which this must not outweigh).
ANCHOR_WEIGHT = 0.1
#: The relative gap at which a model with that pull may stop: the pull only leans the
#: first layout toward the seed's arrangement. Solved closely (0.1 %), it cost a fifth of
#: a batch layout's CPU (0.29 s against 0.23 s on a 5-room flat, 120 seeds, 68 and 69
#: distinct plans; bench/README.md, "Batches").
ANCHOR_GAP = 1.0
#: A diverse solve that stops when good (options.stop_when_good) and whose level 1
#: ended early without a good layout runs level 1 again under another draw, `REDRAWS`
#: times at most, while `REDRAW_MIN_SHARE` of level 1's time is left
#: (solver/pipeline/floor.py); a redraw's seed is the solve's plus `REDRAW_SEED_STEP`
#: times the attempt.
REDRAWS = 2
REDRAW_MIN_SHARE = 0.15
REDRAW_SEED_STEP = 104_729
#: Bases of the Halton sequence, one per coordinate (two per room); beyond them the
#: coordinates are drawn from the seed alone.
_PRIMES = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71,
           73, 79, 83, 89, 97, 101, 103, 107, 109, 113, 127, 131, 137, 139, 149, 151)


def radical_inverse(index: int, base: int) -> float:
    """The `index`-th point of the van der Corput sequence in `base`.

    >>> [radical_inverse(k, 2) for k in range(1, 5)]
    [0.5, 0.25, 0.75, 0.125]
    """
    inverse, scale = 0.0, 1.0 / base
    while index > 0:
        index, digit = divmod(index, base)
        inverse += digit * scale
        scale /= base
    return inverse


def halton_point(index: int, dims: int, shift: random.Random) -> list[float]:
    """Point `index` of a Halton sequence in [0, 1)^dims, every coordinate moved by a
    random offset (modulo 1) drawn from `shift`: spread like the sequence, different
    for every shift."""
    point = []
    for d in range(dims):
        offset = shift.random()
        if d < len(_PRIMES):
            point.append((radical_inverse(index + 1, _PRIMES[d]) + offset) % 1.0)
        else:
            point.append(random.Random(index * 7919 + d).random())
    return point


def drawn_targets(problem: Problem, seed: int) -> Problem:
    """`problem` with each room's target size drawn from `seed` within its bounds.

    A room without both `min_size` and `max_size` keeps its target (nothing says which
    other sizes it allows), as does a fixed one. The draws are scaled together toward
    the floor's free area (by at most `AREA_SCALE_LIMIT`), then clipped to each room's
    bounds; lambda_cover is raised by `COVER_BOOST`."""
    rooms = [r for r in problem.rooms if _drawable(r)]
    if not rooms:
        return problem
    shift = random.Random(zlib.crc32(problem.model_dump_json(include={"boundary", "rooms"})
                                     .encode()))
    point = halton_point(seed % 2**31, 2 * len(rooms), shift)
    drawn: dict[str, tuple[float, float]] = {}
    for k, room in enumerate(rooms):
        assert room.min_size is not None and room.max_size is not None
        drawn[room.id] = (
            room.min_size[0] + point[2 * k] * (room.max_size[0] - room.min_size[0]),
            room.min_size[1] + point[2 * k + 1] * (room.max_size[1] - room.min_size[1]))
    fixed_area = sum(math.prod(r.target_size) for r in problem.rooms
                     if not _drawable(r) and r.target_size is not None)
    want = float(problem.free_area().area) - fixed_area
    have = sum(w * d for w, d in drawn.values())
    scale = 1.0
    if want > 0 and have > 0:
        scale = min(max(math.sqrt(want / have), 1 / AREA_SCALE_LIMIT), AREA_SCALE_LIMIT)
    changed = []
    for room in problem.rooms:
        if room.id not in drawn:
            changed.append(room)
            continue
        assert room.min_size is not None and room.max_size is not None
        target = tuple(round(min(max(drawn[room.id][a] * scale, room.min_size[a]),
                                 room.max_size[a]), 2) for a in range(2))
        changed.append(room.model_copy(update={"target_size": target}))
    weights = problem.weights.model_copy(update={"cover": problem.weights.cover * COVER_BOOST})
    return problem.model_copy(update={"rooms": changed, "weights": weights})


def _drawable(room: Room) -> bool:
    return (room.min_size is not None and room.max_size is not None
            and room.fixed is None)


def pull_at_random(lm: LevelModel, seed: int, *, weight: float = PULL_WEIGHT) -> None:
    """Add to `lm`'s objective a pull of each room's centre along a direction drawn from
    `seed` (the same directions for every model of one seed): a different layout for
    each seed, where the brief allows one."""
    rng = random.Random(seed)
    pull = []
    for r in free_rects(lm.spec):
        if r.name != r.room:  # a room's extra rectangles follow its main one
            continue
        v = lm.rects[r.name]
        ax, ay = rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)
        pull += [ax * (v.x + 0.5 * v.w), ay * (v.y + 0.5 * v.d)]
    if not pull:
        return
    m = lm.model
    m.setObjective(m.getObjective() + weight * quicksum(pull), "minimize")



def drawn_shape(problem: Problem, seed: int) -> Problem:
    """`problem` with, in `L_START_CHANCE` of the seeds, one room drawn from `seed`
    starting as an L (``shape: free``): among the rooms that may have two rectangles or
    more (`max_rects`) and start as one."""
    rng = random.Random(f"shape:{seed}")
    if rng.random() >= L_START_CHANCE:
        return problem
    eligible = [r for r in problem.rooms if may_start_as_l(r)]
    if not eligible:
        return problem
    return started_as_l(problem, rng.choice(eligible).id)


def diverse_problem(problem: Problem, seed: int) -> Problem:
    """The problem a diverse solve searches: `drawn_targets`, then `drawn_shape`."""
    return drawn_shape(drawn_targets(problem, seed), seed)


def _centre_off(name: str, axis: str, point: float, boxes: Boxes) -> float:
    """How far a rectangle's centre is from `point` along `axis`."""
    b = boxes[name]
    return abs((b.x0 + b.x1) / 2 - point if axis == "x" else (b.y0 + b.y1) / 2 - point)


def pull_to_anchors(lm: LevelModel, seed: int, *, weight: float = ANCHOR_WEIGHT) -> None:
    """Add to `lm`'s objective the L1 distance of each room's centre to a point of the
    level's region drawn from `seed` (the same points for every model of one seed),
    times `weight`: the layout SCIP finds first leans toward the seed's arrangement.
    SCIP may stop the model at a gap of `ANCHOR_GAP`."""
    rng = random.Random(f"anchors:{seed}")
    region = lm.spec.region
    points = {r.name: (rng.uniform(region.x0, region.x1), rng.uniform(region.y0, region.y1))
              for r in free_rects(lm.spec) if r.name == r.room}
    if pull_centres(lm, points, weight=weight, tag="anchor"):
        lm.gap = ANCHOR_GAP


def pull_centres(lm: LevelModel, points: Mapping[str, tuple[float, float]], *, weight: float,
                 tag: str) -> bool:
    """Add to `lm`'s objective the L1 distance of each named free rectangle's centre to
    its point of `points` (rectangle name -> (x, y)), times `weight`: two variables and
    four rows a rectangle, each variable with its value at given boxes (a start).
    Whether any term was added."""
    m = lm.model
    terms = []
    for r in free_rects(lm.spec):
        if r.name not in points:
            continue
        v = lm.rects[r.name]
        px, py = points[r.name]
        for axis, centre, point in (("x", v.x + 0.5 * v.w, px), ("y", v.y + 0.5 * v.d, py)):
            # At given boxes: the centre's distance to the point along the axis.
            far = lm.derive(m.addVar(lb=0.0, name=f"{tag}_{axis}[{r.name}]"),
                            partial(_centre_off, r.name, axis, point))
            m.addCons(far >= centre - point, name=f"{tag}_{axis}_above[{r.name}]")
            m.addCons(far >= point - centre, name=f"{tag}_{axis}_below[{r.name}]")
            terms.append(far)
    if terms:
        m.setObjective(m.getObjective() + weight * quicksum(terms), "minimize")
    return bool(terms)
