"""`solve(problem) -> Layout`: level 1, then the hierarchy, then the independent check.

Time policy (paper Sec. 5.4): 5 s up to 20 rooms, growing in proportion beyond. Level 1
gets `LEVEL_ONE_SHARE` of it; the refinement levels share the rest.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, wait
from dataclasses import dataclass, field
from enum import StrEnum

import shapely

from models import (
    ConstraintCheck,
    ExtraRectangles,
    Infeasibility,
    Layout,
    Problem,
    Report,
    RoomLayout,
    Termination,
)
from solver.geometry import (
    Box,
    Domain,
    GeometryError,
    bounding_box,
    domain_lines,
    edges_named,
    make_domain,
    polygon_coords,
    room_polygon,
    snap_rooms,
    unwrapped,
)
from solver.heuristics.construct import construct
from solver.heuristics.level_one import (
    FIRST_BAND,
    demand_order,
    level_one_spec,
    reach_wing,
    target_bands,
    windows_to_try,
    wing_names,
    wings_wanted,
)
from solver.heuristics.neighbourhood import (
    GAP_AREA,
    NEIGHBOURHOOD_SIZE,
    coverage_first,
    covered_area,
    search_neighbourhoods,
)
from solver.heuristics.slicing import slicing_applies, slicing_has_demands, slicing_layout
from solver.miqp.formulation import LevelModel, active_families, build_level, e_band_shortfall
from solver.miqp.scip_run import (
    Incumbent,
    LevelResult,
    LevelStatus,
    complete_start,
    run_level,
)
from solver.openings import add_openings, connection_demands
from solver.pipeline.hierarchy import (
    Piece,
    RefinementPlan,
    SubDomain,
    absorb_gaps,
    absorbed,
    apply_refinement,
    on_edge,
    plan_refinement,
    room_boxes,
    select_subdomains,
)
from solver.pipeline.parallel import (
    LATE_SECONDS,
    LevelOneOutcome,
    LevelOneTask,
    SubdomainExecutor,
    SubdomainOutcome,
    SubdomainTask,
    overlaps_others,
    solve_subdomain,
)
from solver.soft import hard_part, has_soft, room_soft
from solver.verify.checker import COVERAGE_GOAL, check_layout
from solver.verify.conflicts import find_conflict
from solver.verify.precheck import find_impossibilities

#: Seconds per job up to `BASE_ROOMS` rooms (Sec. 5.4) ...
BASE_TIME = 5.0
BASE_ROOMS = 20
#: Share of the time limit level 1 may use.
LEVEL_ONE_SHARE = 0.9
#: The second level-1 search of a portfolio runs under the seed plus this.
SECOND_SEED_STEP = 1_000_003
#: Share of level 1's time one feasibility attempt of the relaxation schedule may use.
ATTEMPT_SHARE = 0.5
#: Time kept per room for closing the last gaps and checking the layout.
FINISH_SECONDS_PER_ROOM = 0.01
#: Python time per room to plan one refinement sub-domain (measured: 0.16 s at 154).
PLAN_SECONDS_PER_ROOM = 0.002
#: Above this many rooms the first layout is built in batches (solver/heuristics/construct.py):
#: one feasibility MILP of all rooms rarely finds anything in time.
CONSTRUCT_ABOVE = 20
#: Share of level 1's time a row plan honouring adjacency and boundary demands may take
#: (solver/heuristics/row_search.py): found in tens of milliseconds when rows can hold them.
SLICE_DEMANDS_SHARE = 0.06
#: Share of the neighbourhood search spent with coverage weighted first.
COVERAGE_PHASE_SHARE = 0.85
#: A fully covering layout's polish ends after this many steps in a row without gain.
STALL_STEPS = 8
#: With soft constraints, the share of level 1's time the search for a layout meeting
#: every constraint may use before the soft model takes over.
STRICT_FIRST_SHARE = 0.5
#: Output coordinates closer than this (metres) are made equal: SCIP's feasibility
#: tolerance is relative, so at 60 m two walls meant to meet may lie 6e-5 m apart.
#: The same tolerance as the checker's.
OUTPUT_SNAP = 1e-4
#: Separates a room's id from the number of a rectangle around an obstacle it wraps.
WRAP_MARK = "~around"
#: Rooms given a second rectangle at level 1 to reach gaps, at most ...
GAP_WINGS = 2
#: ... for gaps larger than this (m²), trying this many rooms per gap.
GAP_WING_AREA = 0.25
WING_TRIES = 3
#: Steps without gain after which a coverage pass gives up (and a gap wing is tried).
COVER_PATIENCE = 6
#: ... or after this share of its time without gain.
COVER_STALL_SHARE = 0.2
#: Share of the floor a layout must cover beyond the checker's goal to count as
#: covering while solving.
COVER_MARGIN = 5e-4


def default_time_limit(rooms: int) -> float:
    """5 s up to 20 rooms, then in proportion to the room count."""
    return BASE_TIME * max(1.0, rooms / BASE_ROOMS)


class Phase(StrEnum):
    RELAXATION = "relaxation"  # a feasibility attempt of the size-window schedule ended
    LEVEL = "level"  # a level starts
    SUBDOMAIN = "subdomain"  # a sub-domain solve ended
    CONFLICT = "conflict"  # the search for constraints that cannot hold together ended
    INCUMBENT = "incumbent"  # SCIP found a better solution of the current MIQP
    DONE = "done"


@dataclass(frozen=True)
class SolveEvent:
    """Progress of a solve, for logs, progress bars and event streams."""

    phase: Phase
    level: int
    elapsed: float
    subdomain: int = 0
    subdomains: int = 0
    objective: float | None = None
    dual_bound: float | None = None
    detail: str = ""
    #: With INCUMBENT: the whole current layout, room id -> rectangles.
    rooms: dict[str, list[Box]] | None = None
    #: In a building of several storeys: the id of the floor being solved.
    floor: str = ""


EventSink = Callable[[SolveEvent], None]


@dataclass
class _Run:
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
    #: The level-1 search ended early, fully covering and no longer improving.
    stalled: bool = False
    #: The problem as the user sent it, before require_connected added to it.
    asked: Problem | None = None
    #: Extra level-1 rectangles per room (issue 8), and the report's account of them.
    wings: dict[str, int] = field(default_factory=dict)
    extra: list[ExtraRectangles] = field(default_factory=list)
    #: The layout comes from the soft model: soft constraints carry priced slacks.
    soft: bool = False
    #: The incumbent of lowest Eq. 12 meeting the coverage goal (gaps absorbed).
    best: tuple[float, dict[str, list[Box]]] | None = None

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
        return self.should_stop is not None and self.should_stop()

    def emit(self, phase: Phase, **kw: object) -> None:
        if self.on_event is not None:
            self.on_event(SolveEvent(phase=phase, level=self.level, elapsed=self.elapsed(),
                                     **kw))  # type: ignore[arg-type]

    def incumbent(self, domain: Domain, rooms: dict[str, list[Box]],
                  dual_bound: float | None = None, sub: int = 0, subs: int = 0) -> None:
        """Keep the layout if it is the best covering one so far, and announce it with
        its Eq. 12 value, as the report counts it: gaps absorbed, as `solve` would
        return it if stopped now."""
        rooms = absorbed(self.problem, domain, rooms)
        objective = layout_objective(self.problem, domain, rooms, soft=self.soft)
        if _covers(domain, rooms) and (self.best is None or objective < self.best[0]):
            self.best = (objective, rooms)
        if self.on_event is not None:
            self.emit(Phase.INCUMBENT, subdomain=sub, subdomains=subs, rooms=rooms,
                      objective=objective, dual_bound=dual_bound)

    def better_of(self, domain: Domain, pieces: list[Piece]) -> list[Piece]:
        """The final `pieces`, unless they miss the coverage goal where an earlier
        incumbent met it, or an earlier covering one scores better: later steps trade
        coverage against size error, and may lose the bet."""
        if self.best is None:
            return pieces
        rooms = room_boxes(pieces)
        objective = layout_objective(self.problem, domain, rooms, soft=self.soft)
        if _covers(domain, rooms) and objective <= self.best[0]:
            return pieces
        return [Piece(f"{room_id}#{k}", room_id, b)
                for room_id, boxes in self.best[1].items() for k, b in enumerate(boxes)]

    def run(self, lm: LevelModel, limit: float, *,
            on_incumbent: Callable[[Incumbent], None] | None = None) -> LevelResult:
        result = run_level(lm, time_limit=limit, seed=self.problem.options.seed,
                           on_incumbent=on_incumbent, should_stop=self.should_stop)
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


def solve(
    problem: Problem,
    *,
    on_event: EventSink | None = None,
    should_stop: Callable[[], bool] | None = None,
    subdomains: SubdomainExecutor | None = None,
) -> Layout:
    """Lay out `problem`: a valid layout, or a report saying why there is none. With
    `subdomains`, the sub-domains of each refinement level are solved at the same time
    on its executor (solver/pipeline/parallel.py); without, one after the other. Problems of
    several storeys go through solver/pipeline/storeys.py; problems with regions, or more rooms
    than `options.regions_above`, through solver/pipeline/regions.py."""
    if problem.floors is not None:  # several storeys: a floor at a time (solver/pipeline/storeys.py)
        from solver.pipeline.storeys import solve_storeys

        return solve_storeys(problem, on_event=on_event, should_stop=should_stop,
                             subdomains=subdomains)
    # Imported here: regions lays out its parts with this very function.
    from solver.pipeline.regions import regions_apply, solve_regions

    if regions_apply(problem):
        return solve_regions(problem, on_event=on_event, should_stop=should_stop)
    started = time.monotonic()
    asked = problem
    # The doors every room needs, as adjacencies the MIQP must honour.
    problem = connection_demands(problem)
    limit = problem.options.time_limit or default_time_limit(len(problem.rooms))
    # The last gaps and the check run after the search: keep time for them.
    reserve = min(limit * 0.1, FINISH_SECONDS_PER_ROOM * len(problem.rooms))
    run = _Run(problem, started + limit - reserve, started, on_event, should_stop, asked=asked)
    domain = make_domain(problem)
    findings = find_impossibilities(problem, domain)  # soft constraints never refuse
    if findings:
        return _no_layout(run, Termination.INFEASIBLE, _explained(run, domain, Infeasibility(
            reason="the problem is infeasible before any solving", findings=findings)))
    run.emit(Phase.LEVEL, detail="level 1: one rectangle per room")
    level_one_end = started + (run.deadline - started) * LEVEL_ONE_SHARE
    second = _second_start(problem, subdomains, level_one_end)
    pieces, failure = _first_level(run, domain, level_one_end)
    if second is not None:
        proven = failure is not None and failure.report.termination is Termination.INFEASIBLE
        if proven or run.stopped():  # nothing the second search finds can be used
            second.cancel()
        else:
            pieces = _better_start(run, domain, pieces, second, level_one_end)
    if pieces is None:
        assert failure is not None
        return failure
    pieces, levels = _refine(run, domain, pieces, subdomains)
    pieces = run.better_of(domain, absorb_gaps(problem, domain, pieces))
    return _layout(run, domain, pieces, levels)


def _first_level(
    run: _Run, domain: Domain, deadline: float
) -> tuple[list[Piece] | None, Layout | None]:
    """Level 1 until `deadline`: the pieces of the first layout, improved, or the
    report of why there is none."""
    problem = run.problem
    if not has_soft(problem):
        return _level_one(run, domain, deadline)
    # Issue 8: a layout meeting every constraint, soft ones too, is looked for first
    # (no price per metre makes a violating layout reliably lose to it); the soft
    # model takes over when there is none, or none found in its share of the time.
    pieces, failure = None, None
    if not find_impossibilities(problem, domain, ignore_soft=False):
        pieces, failure = _level_one(
            run, domain, deadline, explain=False,
            first_by=run.started + (deadline - run.started) * STRICT_FIRST_SHARE)
    if pieces is None and not run.stopped():
        pieces, failure = _soft_level_one(run, domain, deadline)
    return pieces, failure


def _second_start(
    problem: Problem, subdomains: SubdomainExecutor | None, deadline: float
) -> Future[LevelOneOutcome] | None:
    """With an executor of two slots or more, a second level-1 search under another
    seed, alongside this one (`level_one_alone`): level 1's neighbourhood search is a
    local search, and two independent ones end in a better layout more often than one
    (measured in bench/NOTES.md). None when there is no such executor, or it runs
    only sub-domains (a remote one)."""
    if subdomains is None or subdomains.slots < 2:
        return None
    seed = (problem.options.seed + SECOND_SEED_STEP) % 2**31
    task = LevelOneTask(problem.with_options(seed=seed),
                        deadline=time.time() + (deadline - time.monotonic()))
    try:
        return subdomains.executor.submit(level_one_alone, task)
    except (ValueError, RuntimeError):  # an executor for sub-domains only, or shut down
        return None


def level_one_alone(task: LevelOneTask) -> LevelOneOutcome:
    """Level 1 of `task.problem` (its demands already added) in whatever process the
    executor uses, without events or stop flag: it ends by `task.deadline` (epoch)."""
    started = time.monotonic()
    deadline = started + (task.deadline - time.time())
    run = _Run(task.problem, deadline, started, None, None)
    domain = make_domain(task.problem)
    pieces, _ = _first_level(run, domain, deadline)
    return LevelOneOutcome(pieces, run.wings, run.extra, run.window, run.soft,
                           run.relaxations)


def _better_start(
    run: _Run, domain: Domain, pieces: list[Piece] | None,
    second: Future[LevelOneOutcome], deadline: float,
) -> list[Piece] | None:
    """This level 1's pieces, or the second search's when they are better: a layout
    meeting every constraint before one pricing soft ones, then one meeting the
    coverage goal (gaps absorbed), then the lower Eq. 12. The second search is waited
    for until `deadline`, and a little after."""
    while not second.done() and not run.stopped() and (
            time.monotonic() < deadline + LATE_SECONDS):
        wait([second], timeout=0.05)
    try:
        other = second.result(timeout=0)
    except Exception:  # late, stopped, lost or failed: it costs its chance, not the layout
        second.cancel()
        return pieces
    if other.pieces is None or run.stopped():
        return pieces

    def rank(candidate: list[Piece], soft: bool) -> tuple[bool, bool, float]:
        rooms = absorbed(run.problem, domain, room_boxes(candidate))
        return (soft, not _covers(domain, rooms),
                layout_objective(run.problem, domain, rooms, soft=soft))

    if pieces is not None and rank(pieces, run.soft) <= rank(other.pieces, other.soft):
        return pieces
    run.wings, run.extra, run.window, run.soft = (other.wings, other.extra, other.window,
                                                  other.soft)
    run.relaxations.append("a second level-1 search, under another seed, ended better")
    run.emit(Phase.LEVEL, detail="level 1: the second search (another seed) ended better")
    run.incumbent(domain, room_boxes(other.pieces))
    return other.pieces


def _cover(run: _Run, domain: Domain, rects: dict[str, Box]) -> float:
    """The floor level-1 rectangles cover once gaps are absorbed, as `solve` returns it."""
    return _covered(domain, absorbed(run.problem, domain, run.by_room(domain, rects)))


def _covered(domain: Domain, rooms: dict[str, list[Box]]) -> float:
    boxes = {f"{k}#{i}": b for k, bs in rooms.items() for i, b in enumerate(bs)}
    return covered_area(domain, boxes)


def _goal_area(domain: Domain) -> float:
    """The floor the checker's coverage goal asks for, with a margin for the snapping of
    the output walls."""
    return (COVERAGE_GOAL + COVER_MARGIN) * domain.area


def _covers(domain: Domain, rooms: dict[str, list[Box]]) -> bool:
    """Whether `rooms` meet the coverage goal (`_goal_area`)."""
    return _covered(domain, rooms) >= _goal_area(domain)


def _refine(
    run: _Run, domain: Domain, pieces: list[Piece],
    subdomains: SubdomainExecutor | None = None,
) -> tuple[list[Piece], int]:
    """The hierarchy (Sec. 5.3): refine sub-domains level by level while time is left;
    returns the pieces and the number of levels used."""
    problem = run.problem
    levels = 1
    rng = random.Random(problem.options.seed)
    # Planning a sub-domain costs Python time in proportion to the rooms: do not
    # start one that cannot finish.
    overhead = 0.05 + PLAN_SECONDS_PER_ROOM * len(problem.rooms)
    for level in range(2, problem.options.max_levels + 1):
        if run.remaining() <= overhead or run.stopped():
            break
        subs = select_subdomains(problem, domain, pieces)
        if not subs:
            break
        run.level = levels = level
        run.emit(Phase.LEVEL, subdomains=len(subs),
                 detail=f"level {level}: {len(subs)} sub-domain(s)")
        levels_left = problem.options.max_levels - level + 1
        if subdomains is not None and len(subs) > 1:
            level_seconds = run.remaining() / levels_left
            for batch in _disjoint_batches(subs):
                if run.remaining() <= overhead or run.stopped():
                    break
                # Planned from the layout as the previous batch left it.
                plans = [(i, plan_refinement(problem, domain, pieces, sub, level=level,
                                             index=i, rng=rng)) for i, sub in batch]
                seconds = min(level_seconds * len(batch) / len(subs), run.remaining())
                pieces = _refine_at_once(run, domain, pieces, plans, len(subs), seconds,
                                         subdomains)
            continue
        for i, sub in enumerate(subs):
            if run.remaining() <= overhead or run.stopped():
                break
            budget = run.remaining() / levels_left / (len(subs) - i)
            plan = plan_refinement(problem, domain, pieces, sub, level=level, index=i, rng=rng)
            lm = build_level(plan.spec)
            start = complete_start(lm, plan.start, time_limit=budget / 4)
            if start.values is None:
                run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=len(subs),
                         detail=f"start not feasible: {start.status}")
                continue
            result = run.run(lm, budget - start.seconds)
            if result.rects is not None:
                pieces = apply_refinement(pieces, plan, result.rects)
                run.incumbent(domain, room_boxes(pieces), sub=i + 1, subs=len(subs))
            run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=len(subs),
                     objective=result.objective,
                     detail=f"rooms {', '.join(sorted(sub.rooms))}: {result.status}")
    return pieces, levels


def _disjoint_batches(subs: list[SubDomain]) -> list[list[tuple[int, SubDomain]]]:
    """Consecutive runs of sub-domains sharing no room: those are independent problems.
    (Selections too large to merge may share rooms; each such one starts a new batch.)"""
    batches: list[list[tuple[int, SubDomain]]] = []
    taken: set[str] = set()
    for i, sub in enumerate(subs):
        if not batches or taken & sub.rooms:
            batches.append([])
            taken = set()
        batches[-1].append((i, sub))
        taken |= sub.rooms
    return batches


def _refine_at_once(
    run: _Run, domain: Domain, pieces: list[Piece], plans: list[tuple[int, RefinementPlan]],
    total: int, seconds: float, subdomains: SubdomainExecutor,
) -> list[Piece]:
    """Independent sub-domains (`plans`, by their index among the level's `total`)
    solved at the same time within `seconds`, in waves of the executor's slots; results
    applied in order, unless one overlaps rooms placed by an earlier one. A stop
    returns with what has finished."""
    budget = subdomains.budget(seconds, len(plans))
    deadline = time.time() + seconds
    seed = run.problem.options.seed
    futures: dict[Future[SubdomainOutcome], int] = {
        subdomains.executor.submit(
            solve_subdomain, SubdomainTask(plan.spec, plan.start, budget, deadline, seed)): i
        for i, plan in plans}
    outcomes: dict[int, SubdomainOutcome] = {}
    pending = set(futures)
    while pending and not run.stopped() and time.time() < deadline + LATE_SECONDS:
        done, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
        for future in done:
            try:
                outcomes[futures[future]] = future.result()
            except Exception as err:  # a lost task costs its sub-domain, not the layout
                outcomes[futures[future]] = SubdomainOutcome(f"failed: {err}", None, None, 0)
    for future in pending:
        future.cancel()
    n = total
    for i, plan in plans:
        outcome = outcomes.get(i)
        if outcome is None:
            run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=n, detail="stopped")
            continue
        rooms = {h.room for h in plan.pieces.values()}
        if outcome.rects is not None and overlaps_others(
                room_boxes(pieces), rooms, outcome.rects.values()):
            outcome = SubdomainOutcome("dropped: overlaps a neighbouring sub-domain",
                                       None, outcome.objective, outcome.seconds)
        if outcome.rects is not None:
            pieces = apply_refinement(pieces, plan, outcome.rects)
            run.incumbent(domain, room_boxes(pieces), sub=i + 1, subs=n)
        run.emit(Phase.SUBDOMAIN, subdomain=i + 1, subdomains=n, objective=outcome.objective,
                 detail=f"rooms {', '.join(sorted(rooms))}: {outcome.status} "
                        f"in {outcome.seconds:.2f} s")
    return pieces


def _level_one(
    run: _Run, domain: Domain, deadline: float, *, first_by: float | None = None,
    explain: bool = True,
) -> tuple[list[Piece] | None, Layout | None]:
    """Sec. 5.4: find a first layout with size bounds at target +-10 %, widening by 10 %
    until one is found (by `first_by`, else by `deadline`); then improve it under the
    user's own bounds (Eq. 12) until `deadline`. Without `explain`, an infeasible
    problem's answer has no conflict search."""
    problem = run.problem
    improve_by, deadline = deadline, first_by or deadline
    first: LevelResult | None = None
    proven_infeasible = False
    large = len(problem.rooms) > CONSTRUCT_ABOVE
    run.wings = wings_wanted(problem)
    run.extra = [ExtraRectangles(room=room_id, rectangles=count + 1, reason="asked")
                 for room_id, count in run.wings.items()]
    # Keep time for extra rectangles when one rectangle per room is not enough.
    may_widen = len(run.wings) < len(problem.rooms)
    if slicing_applies(problem) and not run.wings:
        # Rows always exist for sizes alone; with demands they may not, so the MIQP
        # keeps most of the time.
        share = SLICE_DEMANDS_SHARE if slicing_has_demands(problem) else 0.5
        first = _slice(run, domain, time.monotonic() + (deadline - time.monotonic()) * share)
    if large and first is None:
        first = _construct(run, domain, time.monotonic() + (deadline - time.monotonic()) / 2)
    for window in [] if first is not None else windows_to_try(problem):
        left = deadline - time.monotonic()
        if left <= 0.05 or run.stopped():
            break
        spec = level_one_spec(problem, domain, window=window, wings=run.wings)
        lm = build_level(spec, feasibility=True)
        if window is None:  # no window held: the user's bounds, sizes pulled to the targets
            e_band_shortfall(lm, target_bands(problem, domain, FIRST_BAND))
        share = left * (ATTEMPT_SHARE if window is not None or may_widen else 1.0)
        result = run.run(lm, share)
        label = "user bounds" if window is None else f"target ±{window:.0%}"
        run.relaxations.append(f"{label}: {result.status}")
        run.emit(Phase.RELAXATION, detail=f"size bounds {label}: {result.status}")
        if result.rects is not None:
            first, run.window = result, window
            break
        proven_infeasible = window is None and result.status is LevelStatus.INFEASIBLE
    if first is None and not proven_infeasible and not large:
        first = _construct(run, domain, deadline - (deadline - time.monotonic()) * (
            ATTEMPT_SHARE if may_widen else 0.0))
    if first is None and may_widen:
        first = _with_wings(run, domain, deadline, why=(
            "one rectangle per room is infeasible (proved by SCIP)" if proven_infeasible
            else "no one-rectangle-per-room layout was found in its share of the time"))
        proven_infeasible = proven_infeasible and first is None
    if first is None:
        spec = level_one_spec(problem, domain, window=None, wings=run.wings)
        if proven_infeasible:
            why = Infeasibility(
                reason="SCIP proved that no single-rectangle layout satisfies the constraints",
                active_families=active_families(spec), relaxations_tried=run.relaxations)
            if explain:
                why = _explained(run, domain, why)
            return None, _no_layout(run, Termination.INFEASIBLE, why)
        if run.stopped():
            termination = Termination.INTERRUPTED
            reason = "stopped on request before any layout was found"
        else:
            termination = Termination.NO_SOLUTION
            reason = "no layout was found within the time limit; feasibility is unknown"
        return None, _no_layout(run, termination, Infeasibility(
            reason=reason, active_families=active_families(spec),
            relaxations_tried=run.relaxations))
    assert first.rects is not None
    run.incumbent(domain, run.by_room(domain, first.rects))
    boxes = _improve_level_one(run, domain, first.rects, improve_by)
    return run.pieces(domain, boxes), None


def _soft_level_one(
    run: _Run, domain: Domain, deadline: float
) -> tuple[list[Piece] | None, Layout | None]:
    """Soft constraints (issue 8): no layout meeting every constraint was found, so the
    soft ones get slacks priced per metre. The first layout minimises the total
    violation alone (a MILP; above `CONSTRUCT_ABOVE` rooms built in batches); then
    Eq. 12 plus that price is minimised as for any problem."""
    problem = run.problem
    run.soft = True
    spec = level_one_spec(problem, domain, window=None, wings=run.wings, soft=True)
    left = deadline - time.monotonic()
    rects: dict[str, Box] | None = None
    status = LevelStatus.NO_SOLUTION
    if len(problem.rooms) > CONSTRUCT_ABOVE and not run.wings:
        rects = construct(spec, deadline=time.monotonic() + left * ATTEMPT_SHARE,
                          rng=random.Random(problem.options.seed),
                          step=lambda model, limit: run.run(model, limit))
    if rects is None and deadline - time.monotonic() > 0.05 and not run.stopped():
        result = run.run(build_level(spec, feasibility=True),
                         (deadline - time.monotonic()) * ATTEMPT_SHARE)
        rects, status = result.rects, result.status
    outcome = "found" if rects is not None else status.value
    run.relaxations.append(f"user bounds, soft constraints priced: {outcome}")
    run.emit(Phase.RELAXATION, detail=f"soft constraints priced: {outcome}")
    if rects is None:
        if status is LevelStatus.INFEASIBLE:
            why = Infeasibility(
                reason="SCIP proved that no single-rectangle layout satisfies the hard "
                "constraints (inside, no overlap, obstacles and those not soft)",
                active_families=active_families(spec), relaxations_tried=run.relaxations)
            return None, _no_layout(run, Termination.INFEASIBLE, _explained(run, domain, why))
        termination = Termination.INTERRUPTED if run.stopped() else Termination.NO_SOLUTION
        return None, _no_layout(run, termination, Infeasibility(
            reason="stopped on request before any layout was found" if run.stopped() else
            "no layout was found within the time limit; feasibility is unknown",
            active_families=active_families(spec), relaxations_tried=run.relaxations))
    run.incumbent(domain, run.by_room(domain, rects))
    boxes = _improve_level_one(run, domain, rects, deadline)
    return run.pieces(domain, boxes), None


def _with_wings(run: _Run, domain: Domain, deadline: float, why: str) -> LevelResult | None:
    """Issue 8: when one rectangle per room fails, let the rooms with the most demands
    start as two rectangles (an L or T), one more room at each attempt, doubling."""
    problem = run.problem
    order = [r for r in demand_order(problem) if r not in run.wings]
    count = 1
    while order and not run.stopped():
        left = deadline - time.monotonic()
        if left <= 0.05:
            return None
        chosen = order[:count]
        last = count >= len(order)
        wings = run.wings | dict.fromkeys(chosen, 1)
        spec = level_one_spec(problem, domain, window=None, wings=wings)
        result = run.run(build_level(spec, feasibility=True),
                         left if last else left * ATTEMPT_SHARE)
        label = f"user bounds, {', '.join(chosen)} as two rectangles"
        run.relaxations.append(f"{label}: {result.status}")
        run.emit(Phase.RELAXATION, detail=f"size bounds {label}: {result.status}")
        if result.rects is not None:
            run.wings = wings
            run.extra += [ExtraRectangles(room=r, rectangles=2, reason=why) for r in chosen]
            return result
        if last:
            return None
        count *= 2
    return None


def _gap_wing(
    run: _Run, domain: Domain, rects: dict[str, Box], deadline: float
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
            start = complete_start(lm, rects | {name: main, wing_names(name, 1)[0]: wing},
                                   time_limit=deadline - time.monotonic())
            if start.rects is None:
                continue
            run.wings = wings
            run.extra.append(ExtraRectangles(
                room=name, rectangles=2,
                reason="a gap beside it stayed uncovered with one rectangle per room"))
            run.emit(Phase.RELAXATION, detail=f"{name} as two rectangles, to reach a gap")
            return lm, start.rects
    return None


def _slice(run: _Run, domain: Domain, deadline: float) -> LevelResult | None:
    """A first layout of rows of rooms filling the floor (solver/heuristics/slicing.py)."""
    started = time.monotonic()
    rects = slicing_layout(run.problem, domain, deadline=deadline,
                           seed=run.problem.options.seed)
    outcome = "found" if rects is not None else "nothing found"
    run.relaxations.append(f"user bounds, sliced into rows: {outcome}")
    run.emit(Phase.RELAXATION, detail=f"size bounds user bounds, sliced into rows: {outcome}")
    if rects is None:
        return None
    return LevelResult(LevelStatus.FEASIBLE, rects, layout_objective(
        run.problem, domain, {k: [b] for k, b in rects.items()}), None,
        time.monotonic() - started)


def _construct(run: _Run, domain: Domain, deadline: float) -> LevelResult | None:
    """A first layout built a batch of rooms at a time (solver/heuristics/construct.py)."""
    if deadline - time.monotonic() <= 0.1 or run.stopped() or run.wings:
        return None
    spec = level_one_spec(run.problem, domain, window=None)
    rects = construct(spec, deadline=deadline, rng=random.Random(run.problem.options.seed),
                      step=lambda model, limit: run.run(model, limit))
    outcome = "found" if rects is not None else "nothing found"
    run.relaxations.append(f"user bounds, built in batches: {outcome}")
    run.emit(Phase.RELAXATION, detail=f"size bounds user bounds, built in batches: {outcome}")
    if rects is None:
        return None
    return LevelResult(LevelStatus.FEASIBLE, rects, None, None, 0.0)


@dataclass(frozen=True)
class _BeforeWing:
    """Level 1 as it stood before a gap wing: its model, rectangles, the floor they
    cover (gaps absorbed) and the run's wings then, to return to if the wing loses."""

    model: LevelModel
    rects: dict[str, Box]
    cover: float
    wings: dict[str, int]
    extra: list[ExtraRectangles]


def _improve_level_one(
    run: _Run, domain: Domain, first: dict[str, Box], deadline: float
) -> dict[str, Box]:
    """Minimise Eq. 12 under the user's own bounds from the first layout, by
    neighbourhood search on the level-1 MIQP."""
    if deadline - time.monotonic() <= 0.1 or run.stopped():
        return first
    lm = build_level(level_one_spec(run.problem, domain, window=None, wings=run.wings,
                                    soft=run.soft))
    start = complete_start(lm, first, time_limit=deadline - time.monotonic())
    if start.values is None:
        return first
    assert start.rects is not None
    if len(run.problem.rooms) <= NEIGHBOURHOOD_SIZE:
        # One neighbourhood would be the whole model: solve it outright.
        def announce(inc: Incumbent) -> None:
            run.incumbent(domain, run.by_room(domain, inc.rects), inc.dual_bound)

        direct = run.run(lm, deadline - time.monotonic(), on_incumbent=announce)
        return direct.rects if direct.rects is not None else start.rects
    def improved(rects: dict[str, Box]) -> None:
        run.incumbent(domain, run.by_room(domain, rects))

    # Coverage first (what users judge a plan by), then the user's own weights without
    # giving coverage back. A start that covers everything skips the first phase, and
    # its search stops once it stalls: only E_size is left to gain, and the user is
    # better served by the layout now than by a few hundredths later.
    rng = random.Random(run.problem.options.seed)
    covers = covered_area(domain, start.rects) >= domain.area - GAP_AREA
    middle = time.monotonic() + (deadline - time.monotonic()) * COVERAGE_PHASE_SHARE

    def good_enough(rects: dict[str, Box]) -> bool:
        return _cover(run, domain, rects) >= _goal_area(domain)

    rects, steps, improvements = start.rects, 0, 0
    stall = (middle - time.monotonic()) * COVER_STALL_SHARE
    wings = 0 if not run.soft else GAP_WINGS
    unwinged: _BeforeWing | None = None
    while not covers:
        last = wings >= GAP_WINGS
        # Growth beyond the targets costs size error: the pass ends once the layout,
        # gaps absorbed, meets the coverage goal, or when it stalls.
        grown = search_neighbourhoods(
            coverage_first(lm.spec), rects, domain, deadline=middle, rng=rng,
            step=lambda model, limit: run.run(model, limit), should_stop=run.should_stop,
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
        if (last or cover >= _goal_area(domain) or time.monotonic() > middle - 0.1
                or run.stopped()):
            break
        # Short of the goal: a room beside the largest gap it can border gets a second
        # rectangle to reach in with (issue 2); when none can, one last pass.
        unwinged = _BeforeWing(lm, rects, cover, dict(run.wings), list(run.extra))
        widened = _gap_wing(run, domain, rects, middle)
        if widened is None:
            wings, unwinged = GAP_WINGS, None
            continue
        lm, rects = widened
        wings += 1
    best = search_neighbourhoods(
        lm.spec, rects, domain,
        deadline=deadline, rng=rng,
        step=lambda model, limit: run.run(model, limit), should_stop=run.should_stop,
        keep_coverage=True, patience=STALL_STEPS if covers else None,
        on_improvement=improved,
    )
    run.stalled = covers and time.monotonic() < deadline - 0.05 and not run.stopped()
    run.emit(Phase.LEVEL, objective=best.objective,
             detail=f"neighbourhood search: {improvements + best.improvements} of "
                    f"{steps + best.steps} steps improved")
    return best.rects


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


def _termination(run: _Run) -> Termination:
    if run.stopped():
        return Termination.INTERRUPTED
    if all(s is LevelStatus.OPTIMAL for s in run.statuses[-1:]) and all(
        s in (LevelStatus.OPTIMAL, LevelStatus.INFEASIBLE) for s in run.statuses
    ):
        return Termination.OPTIMAL
    if run.stalled and run.remaining() > 0:
        return Termination.STALLED
    return Termination.TIME_LIMIT


def _layout(run: _Run, domain: Domain, pieces: list[Piece], levels: int) -> Layout:
    problem = run.problem
    # Walls SCIP placed 1e-7 apart become exactly shared, as a CAD user expects.
    rooms = snap_rooms(room_boxes(pieces), *domain_lines(problem), OUTPUT_SNAP)
    check = check_layout(problem, rooms)
    polygons = {room.id: _outline_of(rooms[room.id]) for room in problem.rooms}
    out = [
        RoomLayout(id=room.id, type=room.type, polygon=polygon_coords(polygons[room.id]),
                   rectangles=[b.to_rect() for b in rooms[room.id]],
                   area=round(float(polygons[room.id].area), 6))
        for room in problem.rooms
    ]
    openings = add_openings(problem, polygons)
    constraints, valid = check.constraints, check.valid
    if problem.options.require_connected:
        connected = openings.circulation is not None and openings.circulation.reachable
        unreachable = openings.circulation.unreachable if openings.circulation else []
        constraints = [*constraints, ConstraintCheck(
            kind="circulation", rooms=unreachable, satisfied=connected,
            detail="every room reachable from the entrance" if connected else
            ("no entrance to start from" if openings.circulation is None else
             f"unreachable: {', '.join(unreachable)}"),
        )]
        if not problem.options.strict:
            # Soft, like the adjacencies require_connected added, which carry the shortfall.
            constraints[-1] = constraints[-1].model_copy(update={"soft": True})
        valid = valid and (connected or not problem.options.strict)
    w = problem.weights
    violations = [c for c in constraints if c.soft and not c.satisfied]
    shortfall = sum(c.shortfall for c in violations)
    objective = (w.cover * check.uncovered_area + w.size * sum(check.size_error.values())
                 + w.violation * shortfall)
    report = Report(
        coverage=check.coverage, uncovered_area=check.uncovered_area,
        constraints=constraints, size_error=check.size_error,
        objective=objective, levels=levels, solve_time=run.elapsed(),
        termination=_termination(run), valid=valid, circulation=openings.circulation,
        relaxation=run.window, extra_rectangles=run.extra,
        violations=violations, total_shortfall=round(shortfall, 6),
    )
    run.emit(Phase.DONE, objective=objective, detail=f"coverage {check.coverage:.1%}")
    return Layout(name=problem.name, rooms=out, doors=openings.doors, windows=openings.windows,
                  report=report)


def _outline_of(boxes: list[Box]) -> shapely.Polygon:
    """A room's polygon. Rectangles that do not form one polygon are a failed
    'connected' check in the report, never an exception: the largest part stands for
    the room's outline, and `rectangles` still lists every piece."""
    try:
        return room_polygon(boxes)
    except GeometryError:
        union = shapely.union_all([b.to_polygon() for b in boxes])
        parts = list(getattr(union, "geoms", [union]))
        return shapely.orient_polygons(max(parts, key=lambda g: g.area))


def draft_layout(problem: Problem, rooms: dict[str, list[Box]], objective: float | None,
                 floor: str = "") -> Layout:
    """An incumbent as a layout for progress displays: polygons and coverage, no check
    (`termination: in_progress`, `valid: false` until the solve ends). In a building of
    several storeys, `floor` names the floor the incumbent is of (`SolveEvent.floor`)."""
    if problem.floors is not None and floor:
        from models.storeys import draft_floor, floor_view

        return draft_floor(problem, floor, draft_layout(floor_view(problem, floor), rooms,
                                                        objective))
    domain_free = problem.free_area()
    out = []
    for room in problem.rooms:
        boxes = rooms.get(room.id, [])
        if not boxes:
            continue
        polygon = _outline_of(boxes)
        area = shapely.union_all([b.to_polygon() for b in boxes]).area
        out.append(RoomLayout(
            id=room.id, type=room.type, polygon=polygon_coords(polygon),
            rectangles=[b.to_rect() for b in boxes], area=round(float(area), 6),
        ))
    covered = shapely.union_all([b.to_polygon() for boxes in rooms.values() for b in boxes])
    cover = float(domain_free.intersection(covered).area)
    report = Report(coverage=cover / domain_free.area if domain_free.area else 1.0,
                    uncovered_area=float(domain_free.area) - cover, objective=objective,
                    termination=Termination.IN_PROGRESS, valid=False)
    return Layout(name=problem.name, rooms=out, report=report)


def _explained(run: _Run, domain: Domain, why: Infeasibility) -> Infeasibility:
    """`why` with a small set of the user's constraints that cannot hold together,
    searched in the time the solve has left (solver/verify/conflicts.py); soft constraints
    never are among them."""
    conflict = find_conflict(hard_part(run.asked or run.problem), domain,
                             deadline=run.deadline, solved=hard_part(run.problem),
                             should_stop=run.should_stop)
    if conflict is not None:
        run.emit(Phase.CONFLICT, detail=f"{len(conflict.constraints)} constraints cannot "
                 f"hold together{'' if conflict.minimal else ' (perhaps not minimal)'}")
    return why.model_copy(update={"conflict": conflict})


def _no_layout(run: _Run, termination: Termination, why: Infeasibility) -> Layout:
    report = Report(coverage=0.0, uncovered_area=0.0, termination=termination, valid=False,
                    infeasibility=why, solve_time=run.elapsed())
    run.emit(Phase.DONE, detail=why.reason)
    return Layout(name=run.problem.name, report=report)
