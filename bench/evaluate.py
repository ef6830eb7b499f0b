"""Judging a solver's trace with the independent checker (solver/verify/checker.py).

A layout is *valid* when the checker passes it (every hard constraint holds) and it
covers at least `COVERAGE_GOAL` of the free area; it *passes* when the checker passes
it whatever its coverage. The recorded layouts are checked in time order, after the
run, until the first of each kind is found.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from bench.solvers import Rooms, Trace
from floorplan.models import Problem
from floorplan.solver.geometry import Domain, bounding_box
from floorplan.solver.pipeline.run import layout_objective
from floorplan.solver.verify.checker import (
    COVERAGE_GOAL,
    SOFT_KINDS,
    CheckResult,
    check_aisles,
    check_layout,
)

#: Layouts whose rectangles overlap, or leave the bounding box, by more than this (m^2)
#: cannot pass the checker (its tolerance is far below), so it is not run on them.
QUICK_TOLERANCE = 1e-3
#: Layouts this far below the coverage goal cannot reach it after the checker's snapping.
QUICK_COVERAGE_SLACK = 0.005


@dataclass
class RunRecord:
    """One run of one solver on one case: every figure of the benchmark."""

    case: str
    solver: str
    repeat: int
    seed: int
    time_limit: float
    status: str
    #: Seconds to the first layout that passes the checker and covers >= 99 %.
    first_valid: float | None
    #: Seconds to the first layout that passes the checker, whatever its coverage.
    first_pass: float | None
    #: Seconds until the solver returned its final layout.
    final_time: float
    #: Seconds to the last improvement of the final layout (last incumbent or snapshot).
    last_improvement: float | None
    coverage: float | None
    hard_violations: int | None
    size_error: float | None
    objective: float | None
    valid: bool
    layouts_recorded: int
    layouts_checked: int
    extra: dict[str, Any]
    #: The anytime profile: [seconds, Eq. 12, coverage] of every recorded layout that
    #: differs from the one before, in time order, ending with the final layout at
    #: `final_time` (its `objective` and `coverage`); bench/anytime.py draws it. Empty
    #: in results.json files written before it was recorded.
    profile: list[list[float]] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def hard_violations(check: CheckResult) -> int:
    """The checker's failed checks other than coverage."""
    return sum(1 for c in check.constraints if not c.satisfied and c.kind not in SOFT_KINDS)


def evaluate(
    problem: Problem, domain: Domain, trace: Trace, *, case: str, repeat: int, seed: int
) -> RunRecord:
    """Every figure of one run, from its trace. A run with aisles (ours through regions)
    is measured as the solver's own report measures it: the aisles count as covered
    floor, and their checks (kind `aisle`) count among the hard violations of the final
    layout. The recorded layouts are checked against the final layout's aisles (the
    trace carries no others; a region's rooms are placed once, so an incumbent's rooms
    are final rooms)."""
    first_valid = first_pass = None
    checked = 0
    for elapsed, rooms in trace.layouts:
        if first_valid is not None:
            break
        if first_pass is not None and _quick_coverage(domain, rooms, trace.aisles) < (
                COVERAGE_GOAL - QUICK_COVERAGE_SLACK):
            continue
        if not _may_pass(domain, rooms):
            continue
        check = check_layout(problem, rooms, aisles=trace.aisles)
        checked += 1
        if not check.valid:
            continue
        if first_pass is None:
            first_pass = elapsed
        if check.coverage >= COVERAGE_GOAL:
            first_valid = elapsed
    coverage = violations = size = objective = None
    valid = False
    if trace.final is not None:
        check = check_layout(problem, trace.final, aisles=trace.aisles)
        checked += 1
        coverage = check.coverage
        violations = hard_violations(check)
        size = sum(check.size_error.values())
        objective = layout_objective(problem, domain, trace.final)
        valid = check.valid and check.coverage >= COVERAGE_GOAL
        if trace.aisles:
            failed = _aisle_failures(problem, trace)
            violations += failed
            valid = valid and not failed
            w = problem.weights
            objective = w.cover * check.uncovered_area + w.size * size
    last = trace.extra.get("last_improvement")
    if last is None and trace.layouts:
        last = _last_change(trace)
    return RunRecord(
        case=case, solver=trace.solver, repeat=repeat, seed=seed,
        time_limit=trace.time_limit, status=trace.status, first_valid=first_valid,
        first_pass=first_pass, final_time=trace.seconds,
        last_improvement=float(last) if last is not None else None,
        coverage=coverage, hard_violations=violations, size_error=size,
        objective=objective, valid=valid, layouts_recorded=len(trace.layouts),
        layouts_checked=checked,
        extra={k: v for k, v in trace.extra.items() if k != "last_improvement"},
        profile=profile_points(problem, domain, trace, objective, coverage),
    )


def profile_points(problem: Problem, domain: Domain, trace: Trace, objective: float | None,
                   coverage: float | None) -> list[list[float]]:
    """Eq. 12 and coverage of each recorded layout over time, so quality against time
    can be drawn from results.json alone. The recorded layouts are measured with the
    rectangles as recorded (no checker, no snapping: cheap, and an invalid layout of the
    annealer still has a value); the final point is the final layout's `objective` and
    `coverage` as the record gives them, so the profile ends where the tables do."""
    points: list[list[float]] = []
    previous: Rooms | None = None
    for elapsed, rooms in trace.layouts:
        if rooms == previous:
            continue
        previous = rooms
        cov, eq12 = _quick_quality(problem, domain, rooms, trace.aisles)
        points.append([round(elapsed, 4), round(eq12, 4), round(cov, 6)])
    if trace.final is not None and objective is not None and coverage is not None:
        # ours and flat record the final layout at `seconds` already: replaced by the
        # record's own figures (the checker's coverage, the aisles' objective), unrounded.
        while points and points[-1][0] >= trace.seconds:
            points.pop()
        points.append([trace.seconds, objective, coverage])
    return points


def _quick_quality(problem: Problem, domain: Domain, rooms: Rooms,
                   aisles: Sequence[BaseGeometry]) -> tuple[float, float]:
    """Coverage and Eq. 12 of a recorded layout (the formula of `layout_objective`,
    with the aisles counted as covered floor), from one union."""
    union = shapely.union_all([b.to_polygon() for boxes in rooms.values() for b in boxes]
                              + list(aisles))
    covered = float(domain.free.intersection(union).area)
    size = 0.0
    for room in problem.rooms:
        if room.target_size is not None and rooms.get(room.id):
            b = bounding_box(rooms[room.id])
            size += (b.width - room.target_size[0]) ** 2 + (b.depth - room.target_size[1]) ** 2
    w = problem.weights
    coverage = covered / domain.area if domain.area else 1.0
    return coverage, w.cover * (domain.area - covered) + w.size * size


def _aisle_failures(problem: Problem, trace: Trace) -> int:
    """The failed aisle checks of the final layout (solver/verify/checker.py `check_aisles`)."""
    assert trace.final is not None
    rooms = {r: shapely.union_all([b.to_polygon() for b in boxes])
             for r, boxes in trace.final.items()}
    aisles = {f"aisle-{k + 1}": a for k, a in enumerate(trace.aisles)}
    checks = check_aisles(problem, rooms, aisles, trace.regions)
    return sum(1 for c in checks if not c.satisfied and c.kind not in SOFT_KINDS)


def _last_change(trace: Trace) -> float:
    """Time of the last recorded layout that differs from the final one (the final
    layout of `ours` is appended when `solve` returns, after its last incumbent)."""
    times = [t for t, _ in trace.layouts]
    if len(times) >= 2 and trace.layouts[-1][1] == trace.layouts[-2][1]:
        return times[-2]
    return times[-1]


def _arrays(rooms: Rooms) -> np.ndarray:
    return np.array([[b.x0, b.y0, b.x1, b.y1] for boxes in rooms.values() for b in boxes])


def _may_pass(domain: Domain, rooms: Rooms) -> bool:
    """False when rectangles of different rooms overlap, or a rectangle sticks out of
    the bounding box, by more than `QUICK_TOLERANCE` m^2 (rectangle arithmetic only)."""
    owners = np.array([k for k, boxes in enumerate(rooms.values()) for _ in boxes])
    r = _arrays(rooms)
    if len(r) == 0:
        return False
    bb = domain.bbox
    area = (r[:, 2] - r[:, 0]) * (r[:, 3] - r[:, 1])
    inside = (np.clip(np.minimum(r[:, 2], bb.x1) - np.maximum(r[:, 0], bb.x0), 0, None)
              * np.clip(np.minimum(r[:, 3], bb.y1) - np.maximum(r[:, 1], bb.y0), 0, None))
    if float(np.max(area - inside)) > QUICK_TOLERANCE:
        return False
    ox = np.clip(np.minimum(r[:, None, 2], r[None, :, 2])
                 - np.maximum(r[:, None, 0], r[None, :, 0]), 0, None)
    oy = np.clip(np.minimum(r[:, None, 3], r[None, :, 3])
                 - np.maximum(r[:, None, 1], r[None, :, 1]), 0, None)
    overlap = ox * oy
    overlap[owners[:, None] == owners[None, :]] = 0.0
    return float(overlap.max()) <= QUICK_TOLERANCE


def _quick_coverage(domain: Domain, rooms: Rooms, aisles: Sequence[BaseGeometry] = ()) -> float:
    union = shapely.union_all([b.to_polygon() for boxes in rooms.values() for b in boxes]
                              + list(aisles))
    return float(domain.free.intersection(union).area) / domain.area if domain.area else 1.0
