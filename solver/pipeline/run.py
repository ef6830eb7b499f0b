"""One solve's book-keeping (`Run`: clock, stop flag, statuses, events, the best
covering incumbent) and Eq. 12 on a layout, shared by every step of the pipeline."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import shapely

from floorplan.models import ExtraRectangles, Problem
from floorplan.solver.budget import significant_gain, stall_window
from floorplan.solver.events import EventSink, Phase, SolveEvent
from floorplan.solver.geometry import (
    Box,
    Domain,
    bounding_box,
    domain_lines,
    edges_named,
    on_edge,
    snap_rooms,
    unwrapped,
)
from floorplan.solver.heuristics.level_one import wing_names
from floorplan.solver.heuristics.neighbourhood import covered_area
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import Incumbent, LevelResult, LevelStatus, run_level
from floorplan.solver.pipeline.absorb import absorbed
from floorplan.solver.pipeline.hierarchy import Piece, as_pieces, room_boxes
from floorplan.solver.soft import room_soft
from floorplan.solver.verify.checker import COVERAGE_GOAL, CheckResult, check_layout

#: Separates a room's id from the number of a rectangle around an obstacle it wraps.
WRAP_MARK = "~around"
#: Output coordinates closer than this (metres) are made equal: SCIP's feasibility
#: tolerance is relative, so at 60 m two walls meant to meet may lie 6e-5 m apart.
#: The same tolerance as the checker's.
OUTPUT_SNAP = 1e-4
#: Covering incumbents kept for falling back on one that passes the checker.
KEPT_BESTS = 8
#: Share of the floor a layout must cover beyond the checker's goal to count as
#: covering while solving.
COVER_MARGIN = 5e-4


@dataclass(frozen=True)
class ScipAnswer:
    """The best solution SCIP returned for a model of the whole floor (level 1 solved
    outright, or SCIP's check of the answer), as rooms, with whether SCIP proved it
    optimal and its dual bound on Eq. 12 (None when the model's objective is not Eq. 12
    itself): what the report may claim when this is the layout returned."""

    rooms: dict[str, list[Box]]
    optimal: bool
    bound: float | None


@dataclass
class Run:
    """Book-keeping of one solve: clock, stop flag, status and events."""

    problem: Problem
    deadline: float
    started: float
    on_event: EventSink | None
    should_stop: Callable[[], bool] | None
    statuses: list[LevelStatus] = field(default_factory=list)
    relaxations: list[str] = field(default_factory=list)
    #: The size window of the first layout (None: the user's own bounds).
    window: float | None = None
    level: int = 1
    #: The problem as the user sent it, before require_connected added to it.
    asked: Problem | None = None
    #: Extra level-1 rectangles per room (docs/method.md, "Rooms of several rectangles"),
    #: and the report's account of them.
    wings: dict[str, int] = field(default_factory=dict)
    #: The extra rectangles of the last level-1 attempt with wings that found nothing.
    tried_wings: dict[str, int] = field(default_factory=dict)
    extra: list[ExtraRectangles] = field(default_factory=list)
    #: The layout comes from the soft model: soft constraints carry priced slacks.
    soft: bool = False
    #: The solve's own end; `deadline` ends the search before it, keeping time for
    #: the reshaping (0: the same as `deadline`).
    end: float = 0.0
    #: Eq. 12 of the best incumbent meeting the coverage goal (gaps absorbed) ...
    best_objective: float | None = None
    #: ... and the covering incumbents that were the best when found, newest (that
    #: one) last, at most `KEPT_BESTS`: the answer falls back on the newest that passes
    #: the checker.
    bests: list[dict[str, list[Box]]] = field(default_factory=list)
    #: When the best covering incumbent last improved by a significant share
    #: (`solver.budget.significant_gain`); None before the first covering one.
    last_gain: float | None = None
    #: The current stage stalled (`options.stop`: "stalled"): it ends, and the next
    #: stage starts its own window (`begin_stage`).
    stage_stalled: bool = False
    #: Stages that ended because they stalled.
    stalls: int = 0
    #: A stage with a stall rule of its own runs (`own_stall_rule`): the time-based one
    #: waits.
    stall_paused: bool = False
    #: The last whole-floor MIQP's answer, if any (`ScipAnswer`).
    scip_answer: ScipAnswer | None = None
    #: SCIP's check of the answer (solver/pipeline/judge.py) runs until then (0: `end`).
    judge_end: float = 0.0
    #: A search with no first layout may go on until then (`FloorBudget.late_by`); 0:
    #: no late allowance (the user gave the limit, or the search is not the floor's own).
    late_by: float = 0.0
    #: The rooms of the last incumbent announced (gaps absorbed), if any.
    announced: dict[str, list[Box]] | None = None
    #: When the first layout was found (`time.monotonic()`), if yet.
    first_at: float | None = None

    def room_of(self, rect: str) -> str:
        """The room a level-1 rectangle belongs to."""
        for room_id, count in self.wings.items():
            if rect in wing_names(room_id, count):
                return room_id
        return rect

    def by_room(self, domain: Domain, rects: dict[str, Box]) -> dict[str, list[Box]]:
        """Level-1 rectangles as each room's floor: a rectangle enclosing an obstacle
        is the rectangles around it."""
        rooms: dict[str, list[Box]] = {}
        for name, b in rects.items():
            rooms.setdefault(self.room_of(name), []).extend(unwrapped(b, domain.notches))
        return rooms

    def pieces(self, domain: Domain, rects: dict[str, Box]) -> list[Piece]:
        """Level-1 rectangles as the hierarchy's pieces. Of a rectangle wrapped around an
        obstacle, the part holding the room's guide points on one of its walls answers
        for the room (the largest such), the others for nothing alone."""
        pieces = []
        for name, b in rects.items():
            room = self.problem.room(self.room_of(name))
            parts = unwrapped(b, domain.notches)
            edges = edges_named(self.problem, domain.edges, room.boundary)
            main = max(parts, key=lambda p: (
                all(p.contains_point(*q) for q in room.positions),
                not edges or any(on_edge(p, e) for e in edges), p.area))
            pieces.append(_piece(self.problem, domain, room.id, name, main))
            pieces += [Piece(f"{name}{WRAP_MARK}{k}", room.id, p)
                       for k, p in enumerate((p for p in parts if p != main), 1)]
        return pieces

    def remaining(self) -> float:
        return self.deadline - time.monotonic()

    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def stopped(self) -> bool:
        """The user (or a stop-when-good rule) asked the solve to stop."""
        return self.should_stop is not None and self.should_stop()

    def stalled_now(self) -> bool:
        """More time is unlikely to buy anything: the best covering layout has not
        improved significantly within the stall window (`solver.budget.stall_window`).
        Never with `options.stop: "limit"`, nor before a covering layout that passes the
        checker exists. Once true, stays true until the next stage begins."""
        if self.stage_stalled:
            return True
        if (self.last_gain is None or self.stall_paused
                or self.problem.options.stop != "stalled"):
            return False
        now = time.monotonic()
        if now - self.last_gain > stall_window(now - self.started):
            if self.passing_best() is None:
                # Every covering layout so far breaks a hard constraint: none is an
                # answer, so the search goes on, and looks again a window later.
                self.last_gain = now
                return False
            self.stage_stalled = True
            self.stalls += 1
        return self.stage_stalled

    def begin_stage(self) -> None:
        """A stage of the portfolio (the level-1 search, the refinement levels, the
        reshaping) starts: it has its own stall window from now, since another method
        may gain where the last one stalled. Before a covering layout exists there is
        nothing to stall on."""
        self.stage_stalled = False
        if self.last_gain is not None:
            self.last_gain = time.monotonic()

    @contextmanager
    def own_stall_rule(self) -> Iterator[None]:
        """A stage that counts its own steps without gain (the neighbourhood search,
        whose steps take a large share of the window) runs with the time-based rule
        paused; the next stage starts afresh (`begin_stage`)."""
        self.stall_paused = True
        try:
            yield
        finally:
            self.stall_paused = False
            self.begin_stage()

    def note_progress(self) -> None:
        """A stage's own measure improved significantly (the reshaping lowers a cost of
        its own before it hands back a layout): its stall window starts again."""
        if self.last_gain is not None and not self.stage_stalled:
            self.last_gain = time.monotonic()

    def ending(self) -> bool:
        """Whether an improving stage should end now: stopped, or stalled. Stages that
        only improve a covering layout take this as their `should_stop`."""
        return self.stopped() or self.stalled_now()

    def emit(self, phase: Phase, **kw: object) -> None:
        if self.on_event is not None:
            self.on_event(SolveEvent(phase=phase, level=self.level, elapsed=self.elapsed(),
                                     **kw))  # type: ignore[arg-type]

    def incumbent(self, domain: Domain, rooms: dict[str, list[Box]],
                  dual_bound: float | None = None, sub: int = 0, subs: int = 0) -> None:
        """Keep the layout if it is the best covering one so far, and announce it with
        its Eq. 12 value, as the report counts it: gaps absorbed, as `solve` would
        return it if stopped now."""
        if self.first_at is None:
            self.first_at = time.monotonic()
        rooms = absorbed(self.problem, domain, rooms)
        objective = layout_objective(self.problem, domain, rooms, soft=self.soft)
        if covers(domain, rooms) and (self.best_objective is None
                                      or objective < self.best_objective):
            if self.best_objective is None or significant_gain(self.best_objective,
                                                               objective):
                self.last_gain = time.monotonic()
            self.best_objective = objective
            self.bests = [*self.bests[1 - KEPT_BESTS:], rooms]
        if self.on_event is not None:
            self.announced = rooms
            self.emit(Phase.INCUMBENT, subdomain=sub, subdomains=subs, rooms=rooms,
                      objective=objective, dual_bound=dual_bound)

    def better_of(self, domain: Domain, pieces: list[Piece]) -> list[Piece]:
        """The final `pieces`, unless they miss the coverage goal where an earlier
        incumbent met it, or an earlier covering one scores better: later steps trade
        coverage against size error, and may lose the bet."""
        if self.best_objective is None:
            return pieces
        rooms = room_boxes(pieces)
        objective = layout_objective(self.problem, domain, rooms, soft=self.soft)
        if covers(domain, rooms) and objective <= self.best_objective:
            return pieces
        return as_pieces(self.bests[-1])

    def passing_best(self) -> tuple[dict[str, list[Box]], CheckResult] | None:
        """The newest of `bests` that the checker passes, as the output gives it
        (snapped), with its check; None when none does."""
        for rooms in reversed(self.bests):
            snapped = snap_rooms(rooms, *domain_lines(self.problem), OUTPUT_SNAP)
            check = check_layout(self.problem, snapped)
            if check.valid:
                return snapped, check
        return None

    def run(self, lm: LevelModel, limit: float, *,
            on_incumbent: Callable[[Incumbent], None] | None = None) -> LevelResult:
        result = run_level(lm, time_limit=limit, seed=self.problem.options.seed,
                           on_incumbent=on_incumbent, should_stop=self.ending)
        self.statuses.append(result.status)
        return result


def layout_objective(problem: Problem, domain: Domain, rooms: dict[str, list[Box]], *,
                     soft: bool = False) -> float:
    """Eq. 12 on a layout: lambda_cover * uncovered area + lambda_size * E_size of the
    rooms with a target, each room measured by its bounding box; with `soft` (a layout
    of the soft model, the only kind that may violate anything) plus the price of the
    soft constraints' shortfalls."""
    union = shapely.union_all([b.to_polygon() for boxes in rooms.values() for b in boxes])
    uncovered = domain.area - float(domain.free.intersection(union).area)
    size = 0.0
    for room in problem.rooms:
        if room.target_size is not None and room.id in rooms:
            b = bounding_box(rooms[room.id])
            size += (b.width - room.target_size[0]) ** 2 + (b.depth - room.target_size[1]) ** 2
    penalty = 0.0
    if soft and all(r.id in rooms for r in problem.rooms):
        # The price of soft violations, as the report counts it.
        checks = check_layout(problem, rooms).constraints
        penalty = problem.weights.violation * sum(
            c.shortfall for c in checks if c.soft and not c.satisfied)
    return problem.weights.cover * uncovered + problem.weights.size * size + penalty


#: Eq. 12 (m²) at or below which a layout counts as exact: its least value, zero, up to
#: the arithmetic of a tiling's sides.
EXACT = 1e-6


def exact(problem: Problem, domain: Domain, rooms: dict[str, list[Box]]) -> bool:
    """Whether `rooms` cover the floor, pass the checker and have Eq. 12 of zero, its
    least value: no search can better them."""
    return (covers(domain, rooms) and layout_objective(problem, domain, rooms) <= EXACT
            and check_layout(problem, rooms).valid)


def covered(domain: Domain, rooms: Mapping[str, Sequence[Box]]) -> float:
    """The floor of `domain` that `rooms` (room id -> rectangles) cover, m²."""
    boxes = {f"{k}#{i}": b for k, bs in rooms.items() for i, b in enumerate(bs)}
    return covered_area(domain, boxes)


def goal_area(domain: Domain) -> float:
    """The floor the checker's coverage goal asks for, with a margin for the snapping of
    the output walls."""
    return (COVERAGE_GOAL + COVER_MARGIN) * domain.area


def covers(domain: Domain, rooms: dict[str, list[Box]]) -> bool:
    """Whether `rooms` meet the coverage goal (`goal_area`)."""
    return covered(domain, rooms) >= goal_area(domain)


def _piece(problem: Problem, domain: Domain, room_id: str, name: str, box: Box) -> Piece:
    room = problem.room(room_id)
    if name != room_id:
        return Piece(name, room_id, box)  # an extra rectangle answers for nothing alone
    # Only the candidate edges the room actually lies on carry over to refinement; a
    # soft demand the room misses keeps them all, so that growing may come nearer.
    named = edges_named(problem, domain.edges, room.boundary)
    edges = tuple(e for e in named if on_edge(box, e))
    soft = room_soft(problem, room)
    if not edges and "boundary" in soft:
        edges = tuple(named)
    return Piece(room_id, room_id, box, tuple(room.positions), edges, soft)
