"""The objective (Eq. 3, 6 and 12) on tiny levels, and every family at once: unique
names, a solvable level."""

from __future__ import annotations

import itertools
import math
from collections import Counter
from collections.abc import Sequence

import pytest

from floorplan.solver.geometry import Box
from floorplan.solver.miqp.formulation import (
    FAMILIES,
    build_level,
    c_inside,
    c_size,
)
from floorplan.solver.miqp.scip_run import LevelStatus, run_level
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, Refine
from tests.solver.miqp.levels import (
    ARGMIN_TOL,
    L_BLOCKED,
    L_EDGES,
    REGION,
    SOLVED,
    TIME_LIMIT,
    TOL,
    level,
    overlap_area,
    rect,
    solve,
)


def energy(w: float, d: float, target: tuple[float, float], ls: float, lc: float) -> float:
    return ls * ((w - target[0]) ** 2 + (d - target[1]) ** 2) - lc * w * d


def argmin_energy(
    target: tuple[float, float],
    w_range: tuple[float, float],
    d_range: tuple[float, float],
    ls: float,
    lc: float,
) -> tuple[float, float]:
    """Minimiser of `energy` over a box (convex: ls >= lc / 2): the stationary point if
    inside, else the best of the four sides' clipped 1-D minimisers."""

    def clip(value: float, bounds: tuple[float, float]) -> float:
        return min(max(value, bounds[0]), bounds[1])

    tw, td = target
    candidates: list[tuple[float, float]] = []
    det = 4 * ls * ls - lc * lc
    if det > 1e-12:
        # 2 ls (w - tw) = lc d and 2 ls (d - td) = lc w
        w = (4 * ls * ls * tw + 2 * ls * lc * td) / det
        d = (4 * ls * ls * td + 2 * ls * lc * tw) / det
        if clip(w, w_range) == w and clip(d, d_range) == d:
            return (w, d)
    for w in w_range:  # a side w = const: d = td + lc w / (2 ls)
        candidates.append((w, clip(td + lc * w / (2 * ls), d_range)))
    for d in d_range:
        candidates.append((clip(tw + lc * d / (2 * ls), w_range), d))
    return min(candidates, key=lambda p: energy(*p, target, ls, lc))


@pytest.mark.parametrize(
    ("target", "min_size", "max_size", "ls", "lc"),
    [
        ((2, 1), (0, 0), (math.inf, math.inf), 1, 1),  # interior: (10/3, 8/3)
        ((2, 1), (0, 0), (3, math.inf), 1, 1),  # width clipped at its max
        ((1, 1), (2.5, 0), (math.inf, math.inf), 1, 1),  # width clipped at its min
        ((5, 3), (0, 0), (math.inf, math.inf), 1, 1),  # clipped to the region
        ((2, 1), (0, 0), (math.inf, math.inf), 3, 1),  # size dominates
        ((2, 1), (0, 0), (math.inf, math.inf), 0.5, 1),  # lambda_size = lambda_cover / 2
    ],
)
def test_e_objective_optimum_is_the_analytic_minimiser(
    target: tuple[float, float],
    min_size: tuple[float, float],
    max_size: tuple[float, float],
    ls: float,
    lc: float,
) -> None:
    spec = level(rect("a", target=target, min_size=min_size, max_size=max_size),
                 size_weight=ls, cover_weight=lc)
    lm = build_level(spec, families=[c_inside, c_size])
    result = solve(lm)
    assert result.status is LevelStatus.OPTIMAL
    assert result.rects is not None
    w_range = (min_size[0], min(max_size[0], REGION.width))
    d_range = (min_size[1], min(max_size[1], REGION.depth))
    w, d = argmin_energy(target, w_range, d_range, ls, lc)
    a = result.rects["a"]
    assert (a.width, a.depth) == pytest.approx((w, d), abs=ARGMIN_TOL)
    assert result.objective == pytest.approx(
        energy(w, d, target, ls, lc) + lc * spec.free_area, abs=ARGMIN_TOL
    )


@pytest.mark.parametrize("ls", [0.5, 1.0, 4.0])
def test_e_objective_is_convex_when_size_weight_is_half_cover_weight(ls: float) -> None:
    # Three rooms with targets in the full level: a convex MIQP solves to optimality fast.
    spec = level(
        rect("a", target=(3, 2)), rect("b", target=(2, 2)), rect("c", target=(1, 3)),
        contacts=[ContactSpec("ab", ("a",), (("b",),), min_contact=1)],
        size_weight=ls, cover_weight=1.0,
    )
    # Proved optimal, not stopped at a limit (ten times the usual one, never reached).
    result = run_level(build_level(spec), time_limit=10 * TIME_LIMIT)
    assert result.status is LevelStatus.OPTIMAL


def full_spec() -> LevelSpec:
    edges = L_EDGES
    return level(
        rect("h0", room="r", target=(2, 2), refine=Refine(Box(0, 0, 4, 2), "vertical", 0, 0.5),
             edges=(edges[0], edges[5])),
        rect("h1", room="r", target=(2, 2), refine=Refine(Box(0, 0, 4, 2), "vertical", 1, 0.5),
             edges=(edges[0],)),
        rect("k", min_size=(1, 1), max_size=(3, 2), aspect_ratio=(1, 2),
             positions=((1, 3), (2, 3.5)), edges=(edges[4], edges[5])),
        rect("s", aspect_ratio=(1, 3), positions=((5, 1),)),
        rect("f", fixed=L_BLOCKED[0]),  # a settled neighbour, also blocked
        blocked=L_BLOCKED,
        contacts=[
            ContactSpec("halves", ("h0",), (("h1",),), min_contact=1.9),
            ContactSpec("k-any", ("k",), (("h0", "h1"), ("s",)), min_contact=1),
            ContactSpec("s-r", ("s",), (("h0", "h1"),), min_contact=1),
            ContactSpec("s-f", ("s",), (("f",),), min_contact=1),
        ],
        envelopes=[EnvelopeSpec("r", ("h0", "h1"), Box(0, 0, 4, 2), (5, 3), (1, 3))],
    )


def duplicates(names: Sequence[str]) -> list[str]:
    return sorted(n for n, k in Counter(names).items() if k > 1)


def test_every_family_builds_with_unique_names() -> None:
    lm = build_level(full_spec())
    assert lm.families == [f.__name__ for f in FAMILIES]
    assert duplicates([c.name for c in lm.model.getConss()]) == []
    assert duplicates([v.name for v in lm.model.getVars()]) == []


def test_every_family_level_is_solvable() -> None:
    result = run_level(build_level(full_spec()), time_limit=TIME_LIMIT)
    assert result.status in SOLVED
    assert result.rects is not None
    assert result.rects["f"] == L_BLOCKED[0]
    for a, b in itertools.combinations(result.rects.values(), 2):
        assert overlap_area(a, b) == pytest.approx(0, abs=TOL)
