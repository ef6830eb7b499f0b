"""Edits around fixed rooms (docs/problem.md, "Fixed rooms"): when most rooms of a brief
are fixed, or some are and a previous layout is the start, only the free ones are laid
out, as one small sub-domain.

The pinned path (`solver.pipeline.fixed.pinned_problem`) keeps every fixed room a room
of each MIQP and runs the whole pipeline (window schedule, neighbourhood search,
hierarchy, reshaping) under the time limit: an edit of a 13-room plan with 9 rooms
fixed then takes seconds, spent on rooms that cannot move. Here the floor the fixed
rooms leave is the domain: its bounding box is the region, everything else in that box
(the fixed rooms, obstacles, the outside) is blocked, and only the free rooms are
variables. A fixed room stays in the MIQP only as constant rectangles that a free
room's adjacency (Eq. 10/11) may name, so contacts with an L-shaped fixed room count
along any of its rectangles.

The search stops as soon as it is good enough (`EditStop`): the free rooms cover their
floor and SCIP stopped improving for a moment, or the gap closed; the skipped stages
(neighbourhood search, reshaping) could not move a fixed wall anyway. A layout that
leaves gaps goes through the hierarchy's refinement and its last gap absorption,
restricted to the free rooms. The answer is checked against the whole problem
(`solver.pipeline.fixed.fixed_layout`); when the edit finds no valid layout, the caller
falls back on the pinned path, which also explains an infeasible edit. When that finds
nothing either, the edit runs again as a last resort with all the time left
(`solver.pipeline.fixed.last_edit`): it holds L-shaped fixed rooms whole, which the
pinned path cannot.

A `start` (room id -> rectangles, `Options.start`) warm-starts the free rooms: a room
that was several rectangles gets as many (up to its allowance), and the start is
completed into a full solution of the MIQP when it is still feasible.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import shapely

from floorplan.models import Problem, Termination
from floorplan.solver.budget import significant_gain, stall_window
from floorplan.solver.events import EventSink, Phase, SolveEvent, StopFlag
from floorplan.solver.geometry import Box, Domain, boundary_edges, rectangles_of
from floorplan.solver.heuristics.level_one import (
    WING_MARK,
    level_one_spec,
    shape_allowance,
    wing_names,
    wings_wanted,
)
from floorplan.solver.heuristics.variety import pull_centres
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import (
    Incumbent,
    LevelResult,
    LevelStatus,
    add_start,
    complete_start,
    run_level,
)
from floorplan.solver.miqp.spec import ContactSpec, LevelSpec, RectSpec, free_rects
from floorplan.solver.openings import connection_demands
from floorplan.solver.pipeline.absorb import absorb_gaps
from floorplan.solver.pipeline.hierarchy import GAP_AREA, room_boxes
from floorplan.solver.pipeline.refine import refine
from floorplan.solver.pipeline.run import COVER_MARGIN, Run, covered
from floorplan.solver.verify.checker import COVERAGE_GOAL

#: The edit path applies when at least this share of the rooms is fixed.
EDIT_SHARE = 0.5
#: Seconds the edit's MIQPs may take at most, whatever the time limit: a small
#: sub-domain either finds a layout within this or needs the full pipeline ...
EDIT_SECONDS = 0.7
#: ... and the edit with the hierarchy after them.
EDIT_END_SECONDS = 1.0
#: Share of the MIQP's time that completing a partial start (some rectangles unplaced)
#: into a full solution may take.
START_SHARE = 0.25
#: Once the free rooms cover their floor, SCIP is stopped after this many seconds
#: without a better incumbent ...
STALL_SECONDS = 0.15
#: ... or as soon as its own gap (primal - dual over |primal|, at least 1) is this small.
EDIT_GAP = 0.02
#: A search that found layouts leaving gaps ends this long after its last better one
#: at the earliest (`EditStop`).
UNCOVERED_STALL = 1.0
#: A start's rectangle narrower than this (metres) is no arm of its room: a sliver.
START_ARM = 0.5
#: Weight of the edit's stability term per metre a free room's centre moves from the
#: start (Eq. 12 is in m²): it breaks near-ties toward the plan as it was, and outweighs
#: no real gain in coverage or size.
STAY_WEIGHT = 0.25
#: Marks the name of a fixed room's rectangle in the edit's MIQP.
FIXED_MARK = "~fixed"


@dataclass
class EditStop:
    """When the edit's SCIP search is good enough: the free rooms cover `goal` of their
    floor and the search stalled for `STALL_SECONDS`, or its gap closed to `EDIT_GAP`.
    A search whose layouts leave gaps (the hierarchy fills them) ends when it has not
    improved for `solver.budget.stall_window` of its time and `UNCOVERED_STALL` seconds:
    only a long search (the last resort's) gets there."""

    domain: Domain
    free: frozenset[str]
    #: The floor the free rooms must cover.
    goal: float
    covered_at: float | None = None
    improved_at: float = field(default_factory=time.monotonic)
    gap: float = float("inf")
    began: float = field(default_factory=time.monotonic)
    found: bool = False
    best: float | None = None

    def incumbent(self, found: Incumbent) -> None:
        now = time.monotonic()
        if self.best is None or significant_gain(self.best, found.objective):
            # Only a gain a user would see restarts the stall clock: the stability term
            # (`stay_near_start`) improves by centimetres long after the plan is set.
            self.improved_at = now
        self.best = found.objective if self.best is None else min(self.best, found.objective)
        self.found = True
        rooms = {n: [b] for n, b in found.rects.items() if FIXED_MARK not in n}
        if self.covered_at is None and covered(self.domain, rooms) >= self.goal:
            self.covered_at = now
        self.gap = (found.objective - found.dual_bound) / max(abs(found.objective), 1.0)

    def __call__(self) -> bool:
        now = time.monotonic()
        if self.covered_at is None:
            return self.found and now - self.improved_at >= max(
                UNCOVERED_STALL, stall_window(self.improved_at - self.began))
        return self.gap <= EDIT_GAP or now - self.improved_at >= STALL_SECONDS


def most_fixed(problem: Problem) -> bool:
    """Whether at least `EDIT_SHARE` of the rooms of `problem` (one floor) are fixed."""
    return sum(room.fixed is not None for room in problem.rooms) >= EDIT_SHARE * len(
        problem.rooms)


def edit_applies(problem: Problem) -> bool:
    """Whether `problem` (one floor) is an edit: some rooms free, and most of them fixed
    or some fixed with a previous layout as `options.start` (an edit of that layout,
    whose kept rooms the pinned path would hold by their largest rectangles only)."""
    fixed = sum(room.fixed is not None for room in problem.rooms)
    if not 0 < fixed < len(problem.rooms):
        return False
    return most_fixed(problem) or problem.options.start is not None


def edit_domain(problem: Problem, fixed: Mapping[str, list[Box]]) -> Domain | None:
    """The floor the fixed rooms leave, as a domain whose box is that floor's bounding
    box; None when they leave none."""
    taken = shapely.union_all([b.to_polygon() for boxes in fixed.values() for b in boxes])
    free = problem.free_area().difference(taken)
    if free.area <= GAP_AREA:
        return None
    x0, y0, x1, y1 = free.bounds
    bbox = Box(x0, y0, x1, y1)
    blocked = tuple(b for b in rectangles_of(bbox.to_polygon().difference(free))
                    if b.width * b.depth > 0)
    return Domain(bbox=bbox, free=free, blocked=blocked,
                  edges=boundary_edges(problem.boundary))


def free_problem(problem: Problem) -> Problem:
    """`problem` with its free rooms only, and the adjacencies among them; never
    partitioned into regions. Not validated again: it is a part of a valid problem."""
    free = {room.id for room in problem.rooms if room.fixed is None}
    adjacency = [a for a in problem.adjacency if {a.a, *a.partners} <= free]
    options = problem.options.model_copy(update={"regions_above": 0})
    return problem.model_copy(update={
        "rooms": [room for room in problem.rooms if room.id in free],
        "adjacency": adjacency, "options": options})


def start_wings(sub: Problem, start: Mapping[str, list[Box]]) -> dict[str, int]:
    """Extra level-1 rectangles per free room: as many as the room had in `start`
    beyond one, counting only arms at least `START_ARM` wide and deep (slivers are
    left to the gap absorption), within its allowance; at least as many as it asks
    for up front."""
    wings = wings_wanted(sub)
    for room in sub.rooms:
        arms = [b for b in start.get(room.id, []) if min(b.width, b.depth) >= START_ARM]
        if arms:
            wings[room.id] = max(wings.get(room.id, 0),
                                 min(len(arms), shape_allowance(room)) - 1)
    return {r: n for r, n in wings.items() if n > 0}


def edit_spec(problem: Problem, sub: Problem, domain: Domain, fixed: Mapping[str, list[Box]],
              wings: Mapping[str, int]) -> LevelSpec:
    """The edit's MIQP: level 1 of the free rooms in `domain`, plus each adjacency of
    `problem` (its demands added) between a free room and fixed ones, against the
    fixed rooms' rectangles held as constants."""
    spec = level_one_spec(sub, domain, window=None, wings=wings, wrap=False)
    free = {room.id for room in sub.rooms}

    def parts(room_id: str) -> tuple[str, ...]:
        if room_id in fixed:
            return tuple(f"{room_id}{FIXED_MARK}{k}" for k in range(len(fixed[room_id])))
        return (room_id, *wing_names(room_id, wings.get(room_id, 0)))

    contacts, named = [], set()
    for k, adj in enumerate(problem.adjacency):
        members = {adj.a, *adj.partners}
        if members <= free or not members & free:
            continue  # among free rooms: in level 1 already; among fixed: the check's
        contact = ContactSpec(name=f"fixed_adj{k}", a=parts(adj.a),
                              partners=tuple(parts(p) for p in adj.partners),
                              min_contact=adj.min_contact)
        contacts.append(contact)
        named |= {room for room in members if room in fixed}
    held = [RectSpec(name=name, room=room, fixed=b)
            for room in sorted(named) for name, b in zip(parts(room), fixed[room], strict=True)]
    return replace(spec, name=f"{problem.name}/edit", rects=(*spec.rects, *held),
                   contacts=(*spec.contacts, *contacts))


@dataclass(frozen=True)
class EditResult:
    """The free rooms' rectangles (None: no layout) and how the search ended."""

    rooms: dict[str, list[Box]] | None
    termination: Termination
    levels: int
    status: str


def solve_edit(
    problem: Problem,
    fixed: Mapping[str, list[Box]],
    *,
    deadline: float,
    start: Mapping[str, list[Box]] | None = None,
    on_event: EventSink | None = None,
    should_stop: StopFlag | None = None,
    seconds: float = EDIT_SECONDS,
    first: bool = False,
) -> EditResult:
    """Lay out the free rooms of `problem` around the `fixed` rooms' rectangles, by
    `deadline` (monotonic): one MIQP of the free rooms, stopped when good enough, then
    the hierarchy's refinement and gap absorption when it leaves gaps. A room that
    cannot be one rectangle in what the fixed rooms leave gets wings: the shapes of
    `start`, then an L for every free room, then up to a T (`wing_plans`). The MIQPs
    take `seconds` at most (the hierarchy after them `EDIT_END_SECONDS -
    EDIT_SECONDS` more): a quick first try, or all the time left as a last resort, which
    takes the `first` layout found rather than trying further shapes for more floor."""
    started = time.monotonic()
    demanded = connection_demands(problem)
    sub = free_problem(demanded)
    domain = edit_domain(problem, fixed)
    if domain is None:
        return EditResult({}, Termination.OPTIMAL, 1, "nothing to lay out")
    # The whole floor's coverage goal, met by the free rooms alone: the fixed ones
    # cover exactly their polygons.
    allowed = domain.area - (1 - COVERAGE_GOAL - COVER_MARGIN) * problem.free_area().area
    start = {r: boxes for r, boxes in (start or {}).items() if r in {x.id for x in sub.rooms}}
    end = min(deadline, started + seconds)
    run = Run(sub, end, started, _with_fixed(on_event, fixed), should_stop, asked=sub,
              end=end)
    # The hierarchy after the MIQPs ends this much later.
    refined = min(deadline, started + seconds + EDIT_END_SECONDS - EDIT_SECONDS)
    run.emit(Phase.LEVEL, detail=f"edit: {len(sub.rooms)} free room(s) around "
             f"{len(fixed)} fixed")
    best: tuple[float, EditResult] | None = None  # the most floor covered, and by what
    status = "no attempt"
    plans = wing_plans(sub, start)
    for k, wings in enumerate(plans):
        now = time.monotonic()
        if now >= end or run.stopped():
            break
        # Each plan left gets its share of the time, at least `EDIT_SECONDS`: one MIQP
        # that neither finds nor refutes a layout leaves the other shapes their turn.
        run.deadline = min(end, now + max(EDIT_SECONDS, (end - now) / (len(plans) - k)))
        result = _attempt(run, demanded, sub, domain, fixed, wings, start, allowed,
                          max(refined, run.deadline))
        status = result.status
        if result.rooms is None:
            continue
        area = covered(domain, result.rooms)
        if area >= allowed or first:
            return result
        if best is None or area > best[0]:
            best = (area, result)
    return best[1] if best else EditResult(None, Termination.NO_SOLUTION, 1, status)


def wing_plans(sub: Problem, start: Mapping[str, list[Box]]) -> list[dict[str, int]]:
    """The extra rectangles to try per free room, in turn: what rooms ask for (the
    smallest MIQP, proved impossible in milliseconds when it is), the start's shapes,
    one more for each room that may be an L, then up to its allowance (a T, U or Z)."""
    wanted = {r: n for r, n in wings_wanted(sub).items() if n > 0}
    plans = [wanted]
    for plan in (start_wings(sub, start), *(
            {room.id: max(wanted.get(room.id, 0), min(extra, shape_allowance(room) - 1))
             for room in sub.rooms} for extra in (1, 2))):
        plan = {r: n for r, n in plan.items() if n > 0}
        if plan not in plans:
            plans.append(plan)
    return plans


def _attempt(run: Run, demanded: Problem, sub: Problem, domain: Domain,
             fixed: Mapping[str, list[Box]], wings: dict[str, int],
             start: Mapping[str, list[Box]], allowed: float, refined: float) -> EditResult:
    """One MIQP of the free rooms with `wings`, and the hierarchy after it (until
    `refined`, monotonic) when it leaves more floor uncovered than `allowed`."""
    run.wings = wings
    end = run.deadline
    rects = _start_rects(start, wings)
    lm = build_level(_fit_start(edit_spec(demanded, sub, domain, fixed, wings), rects))
    if start:
        # A start that places every free rectangle is a full solution in closed form.
        # One with fewer rectangles than the wings tried, or without some room, leaves
        # rectangles to place: only a SCIP solve around the placed ones completes it.
        full = all(r.name in rects for r in free_rects(lm.spec))
        began = (add_start(lm, rects) if full
                 else complete_start(lm, rects,
                                     time_limit=(end - time.monotonic()) * START_SHARE))
        run.emit(Phase.LEVEL, detail="edit: the start " + (
            "holds, SCIP starts from it" if began.values is not None
            else f"does not hold ({began.status}), SCIP starts afresh"))
        if full and began.values is None:
            # Searching afresh, SCIP is pulled toward the plan as it was. (A start that
            # holds needs no pull: SCIP starts from it, and with the pull's variables
            # it no longer reports that start as its first incumbent, so the edit's
            # stop rule, which waits for one, would wait for its limit.)
            stay_near_start(lm, rects)
    stop = EditStop(domain, frozenset(r.id for r in sub.rooms), allowed)

    def on_incumbent(found: Incumbent) -> None:
        stop.incumbent(found)
        rooms = run.by_room(domain, {n: b for n, b in found.rects.items()
                                     if FIXED_MARK not in n})
        run.incumbent(domain, rooms, dual_bound=found.dual_bound)

    result: LevelResult = run_level(
        lm, time_limit=end - time.monotonic(), seed=sub.options.seed,
        on_incumbent=on_incumbent, should_stop=lambda: run.stopped() or stop())
    if result.rects is None:
        return EditResult(None, Termination.NO_SOLUTION, 1, str(result.status))
    pieces = run.pieces(domain, {n: b for n, b in result.rects.items()
                                 if FIXED_MARK not in n})
    levels = 1
    if covered(domain, room_boxes(pieces)) < allowed:
        # Gaps: the hierarchy grows the free rooms into them, then the last absorption.
        run.deadline = refined
        pieces, levels = refine(run, domain, pieces)
        pieces = absorb_gaps(sub, domain, pieces)
        run.deadline = end
    ended = (Termination.INTERRUPTED if run.stopped() else
             Termination.OPTIMAL if result.status is LevelStatus.OPTIMAL else
             Termination.STALLED if result.status is LevelStatus.INTERRUPTED else
             Termination.TIME_LIMIT)
    return EditResult(room_boxes(pieces), ended, levels, str(result.status))


def stay_near_start(lm: LevelModel, rects: Mapping[str, Box],
                    weight: float = STAY_WEIGHT) -> None:
    """Stability as part of the edit's objective: each free room's main rectangle is
    pulled toward where the start had it, `weight` times the L1 distance (metres) of its
    centre to the start's (`solver.heuristics.variety.pull_centres`), so that of layouts
    nearly as good the one moving the rooms least wins; a room the start lacks is free.
    For a start that no longer holds (a room's size changed): one that holds is SCIP's
    start, and moves nothing."""
    points = {r.name: ((b.x0 + b.x1) / 2, (b.y0 + b.y1) / 2) for r in free_rects(lm.spec)
              if r.name == r.room and (b := rects.get(r.name)) is not None}
    pull_centres(lm, points, weight=weight, tag="stay")


def _start_rects(start: Mapping[str, list[Box]], wings: Mapping[str, int]) -> dict[str, Box]:
    """A start's rooms as the MIQP's rectangles: the largest is the room's main one, the
    next ones its wings; rectangles beyond those are left out (the start then holds
    only if the room's constraints do without them)."""
    rects: dict[str, Box] = {}
    for room_id, boxes in start.items():
        names = (room_id, *wing_names(room_id, wings.get(room_id, 0)))
        ordered = sorted(boxes, key=lambda b: -b.width * b.depth)
        rects.update(zip(names, ordered, strict=False))
    return rects


def _fit_start(spec: LevelSpec, rects: Mapping[str, Box]) -> LevelSpec:
    """`spec` with each wing's minimum size lowered to its starting rectangle's, where
    that is smaller: the previous layout's arms stay possible (level 1 asks
    `WING_MIN` of a new arm)."""
    fitted = []
    for r in spec.rects:
        b = rects.get(r.name)
        if b is not None and WING_MARK in r.name:
            r = replace(r, min_size=(min(r.min_size[0], b.width), min(r.min_size[1], b.depth)))
        fitted.append(r)
    return replace(spec, rects=tuple(fitted))


def _with_fixed(on_event: EventSink | None, fixed: Mapping[str, list[Box]]
                ) -> EventSink | None:
    """`on_event` with the fixed rooms added to each incumbent's rooms, so a live plan
    shows the whole floor."""
    if on_event is None:
        return None

    def sink(event: SolveEvent) -> None:
        if event.rooms is not None:
            event = replace(event, rooms={**fixed, **event.rooms})
        on_event(event)

    return sink
