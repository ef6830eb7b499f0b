"""Different plans from different seeds (issue 23, batches): with `options.diverse`, the
seed draws a direction for every room and the level-1 improvement leans that way.

A brief usually leaves room for several arrangements (the kitchen east or west of the
living room, the bathroom before or behind the bedroom), but Eq. 12 prefers one of them
by a few hundredths, and the search finds that one from nearly every start. With
`pull_at_random` on the improvement's model (Eq. 12) the pull breaks the near-ties of
Eq. 12 the seed's way, at a price of at most `PULL_WEIGHT` per metre a room's centre
moves.

Measured (issue 23, bench/README.md#batches): the same pull on the first layout's model
(whose objective is zero within a size window) gives very different first layouts, but
on apartment-5 the improvement brings them back to the same few plans all the same, and
on house-13 the pulled starts cost coverage (0.95 instead of 0.995 at 5.2 s): it is not
used there. Arrangements kept through the improvement (the pull's first layout, its
C_overlap sides fixed) rarely reach the coverage goal with one rectangle per room.
"""

from __future__ import annotations

import random

from pyscipopt import quicksum

from solver.miqp.model import LevelModel
from solver.miqp.spec import free_rects

#: Weight of the random pull per metre a room's centre moves, against Eq. 12 (m²):
#: small, so that it chooses among layouts Eq. 12 finds nearly equal rather than
#: overruling coverage or sizes.
PULL_WEIGHT = 0.05


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
