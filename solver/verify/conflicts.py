"""Explained conflicts: when no layout exists, a small set of the user's own constraints
that cannot hold together, each named by its path and put in words.

A *group* is one constraint of the request: one axis of a room's minimum or maximum
size, its aspect ratio, one guide point, its boundary list (touch one of the edges: a
single demand), one adjacency entry, and what ``options.require_connected`` added. The
outline and the obstacles are facts, not groups. Dropping a group only relaxes the
problem, so infeasibility is monotone in the groups and a deletion filter finds an
irreducible set: start from every group (known infeasible), try without some, drop
them for good when the rest stays provably infeasible, keep them otherwise. A check
asks the cheap prechecks first (a finding is a proof), then SCIP about the level-1
model (one rectangle per room, the user's bounds, zero objective).

What keeps it fast changes no answer. Whole rooms go first, each with every group
naming it: rooms far from the conflict leave in a few checks and the group phase
solves small models. Candidates are tried in chunks that double after a drop and halve
when a chunk holds a needed group: k needed out of n cost about k log(n/k) checks when
few are needed, about n when most are. And an infeasibility the prechecks proved is
first shrunk with the prechecks alone, in milliseconds. A check left unsettled (SCIP
out of time, or not asked: `MAX_SCIP_ROOMS`, `MAX_UNDECIDED`) keeps its group, and the
set is then reported as possibly not minimal.

A room left with no group is left out of the model: as a zero-size rectangle on a
vertex of the outline it is clear of every room and every blocked box, so it never
decides feasibility.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TypeVar

from floorplan.models import ConflictSet, Problem
from floorplan.solver.geometry import EPS, Domain, make_domain
from floorplan.solver.heuristics.level_one import level_one_spec, wings_wanted
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.scip_run import LevelStatus, run_level
from floorplan.solver.openings import connection_demands
from floorplan.solver.soft import hard_part
from floorplan.solver.verify.conflict_groups import (
    DROP_ORDER,
    Group,
    Kind,
    describe_all,
    explanation,
)
from floorplan.solver.verify.precheck import find_impossibilities

#: A SCIP check gets this share of the time left ...
CHECK_SHARE = 0.25

#: ... but at least this many seconds (while that much is left) and at most this many:
#: checks on the models of a few rooms decide in milliseconds, and one that has not
#: decided in seconds is a packing SCIP is unlikely to settle at all.
CHECK_FLOOR = 0.5

CHECK_CAP = 2.0

#: After this many undecided SCIP checks the rest are judged by the prechecks alone:
#: each undecided one costs its whole limit and teaches nothing.
MAX_UNDECIDED = 3

#: SCIP is asked only about models of at most this many rooms: beyond, one MILP of
#: all rooms rarely settles anything in seconds (the pipeline builds large first layouts
#: in batches for that reason), and building it alone takes a good part of a second.
MAX_SCIP_ROOMS = 20

#: No check is started with less than this many seconds left.
MIN_CHECK = 0.05

#: `diagnose`: share of its time the first check (is the whole problem feasible?) may use.
FIRST_CHECK_SHARE = 0.5

T = TypeVar("T")


class Verdict(StrEnum):
    """What one check says about a set of groups."""

    INFEASIBLE = "infeasible"  # proven, by a precheck finding or by SCIP
    FEASIBLE = "feasible"  # SCIP found a level-1 layout
    UNDECIDED = "undecided"  # neither within the time given


def constraint_groups(problem: Problem, asked: Problem) -> list[Group]:
    """Every constraint of `problem`, which is `asked` with what require_connected
    added (appended adjacencies and at most one appended guide point)."""
    groups: list[Group] = []
    for i, room in enumerate(problem.rooms):
        named = frozenset({i})
        for axis in range(2):
            if room.min_size is not None and room.min_size[axis] > EPS:
                groups.append(Group(Kind.MIN_SIZE, i, axis, named))
            if room.max_size is not None:
                groups.append(Group(Kind.MAX_SIZE, i, axis, named))
        if room.aspect_ratio is not None:
            groups.append(Group(Kind.ASPECT_RATIO, i, 0, named))
        own = len(asked.rooms[i].positions)
        for p in range(len(room.positions)):
            groups.append(Group(Kind.POSITION if p < own else Kind.ENTRANCE, i, p, named))
        if room.boundary:
            groups.append(Group(Kind.BOUNDARY, i, 0, named))
    index = {room.id: i for i, room in enumerate(problem.rooms)}
    own = len(asked.adjacency)
    for k, adj in enumerate(problem.adjacency):
        named = frozenset(index[r] for r in (adj.a, *adj.partners))
        groups.append(Group(Kind.ADJACENCY if k < own else Kind.CONNECTION, None, k, named))
    return groups


@dataclass
class _RoomDraft:
    """The constraints a room keeps in a restricted problem."""

    min_size: list[float] = field(default_factory=lambda: [0.0, 0.0])
    max_size: list[float] = field(default_factory=lambda: [math.inf, math.inf])
    aspect_ratio: tuple[float, float] | None = None
    positions: dict[int, tuple[float, float]] = field(default_factory=dict)
    boundary: list[int | str] = field(default_factory=list)


def restricted(problem: Problem, groups: Collection[Group]) -> Problem:
    """`problem` with only `groups` as constraints. Rooms no group names are left out
    (see the module docstring); targets go, as they constrain nothing."""
    drafts: dict[int, _RoomDraft] = {}
    adjacency: list[int] = []
    for g in groups:
        for i in g.rooms:
            drafts.setdefault(i, _RoomDraft())
        if g.room is None:
            adjacency.append(g.index)
            continue
        room, draft = problem.rooms[g.room], drafts[g.room]
        match g.kind:
            case Kind.MIN_SIZE:
                assert room.min_size is not None
                draft.min_size[g.index] = room.min_size[g.index]
            case Kind.MAX_SIZE:
                assert room.max_size is not None
                draft.max_size[g.index] = room.max_size[g.index]
            case Kind.ASPECT_RATIO:
                draft.aspect_ratio = room.aspect_ratio
            case Kind.POSITION | Kind.ENTRANCE:
                draft.positions[g.index] = room.positions[g.index]
            case Kind.BOUNDARY:
                draft.boundary = list(room.boundary)
    rooms = [
        problem.rooms[i].model_copy(update={
            "min_size": tuple(d.min_size),
            # model_copy does not validate: an unbounded axis may be infinite.
            "max_size": None if all(map(math.isinf, d.max_size)) else tuple(d.max_size),
            "target_size": None,
            "aspect_ratio": d.aspect_ratio,
            "positions": [d.positions[p] for p in sorted(d.positions)],
            "boundary": d.boundary,
        })
        for i, d in sorted(drafts.items())
    ]
    return problem.model_copy(update={
        "rooms": rooms, "adjacency": [problem.adjacency[k] for k in sorted(adjacency)]})


def level_one_verdict(
    problem: Problem, domain: Domain, groups: Collection[Group], *, time_limit: float,
    should_stop: Callable[[], bool] | None = None,
) -> Verdict:
    """Can every constraint in `groups` hold at once, each room one rectangle (or the
    ones it asks for)? The prechecks, then SCIP within `time_limit` (0: the prechecks
    alone)."""
    if not groups:
        return Verdict.FEASIBLE
    sub = restricted(problem, groups)
    if find_impossibilities(sub, domain):
        return Verdict.INFEASIBLE
    if not scip_may_decide(sub, time_limit):
        return Verdict.UNDECIDED
    # The rooms that ask for more than one rectangle get them, as in solve's level 1.
    spec = level_one_spec(sub, domain, window=None, wings=wings_wanted(sub))
    lm = build_level(spec, feasibility=True)
    result = run_level(lm, time_limit=time_limit, should_stop=should_stop)
    if result.status is LevelStatus.INFEASIBLE:
        return Verdict.INFEASIBLE
    return Verdict.FEASIBLE if result.rects is not None else Verdict.UNDECIDED


def scip_may_decide(problem: Problem, time_limit: float) -> bool:
    """Whether asking SCIP about `problem` within `time_limit` is worth it."""
    return time_limit >= MIN_CHECK and len(problem.rooms) <= MAX_SCIP_ROOMS


@dataclass
class _Checker:
    """Level-1 checks within a deadline, each remembered."""

    problem: Problem
    domain: Domain
    deadline: float
    should_stop: Callable[[], bool] | None
    checks: int = 0
    undecided: int = 0
    _seen: dict[frozenset[Group], Verdict] = field(default_factory=dict)
    #: Sets the prechecks alone left undecided, still to be shown to SCIP when asked.
    _prechecked: set[frozenset[Group]] = field(default_factory=set)

    def out_of_time(self) -> bool:
        stopped = self.should_stop is not None and self.should_stop()
        return stopped or self.deadline - time.monotonic() < MIN_CHECK

    def __call__(self, groups: Collection[Group]) -> Verdict:
        """The prechecks, then SCIP."""
        return self._verdict(groups, scip=True)

    def by_prechecks(self, groups: Collection[Group]) -> Verdict:
        """The prechecks alone: infeasible or undecided, in milliseconds."""
        return self._verdict(groups, scip=False)

    def _verdict(self, groups: Collection[Group], *, scip: bool) -> Verdict:
        key = frozenset(groups)
        # Sets of many rooms SCIP is not asked about: the prechecks' verdict stands.
        retry = scip and key in self._prechecked and \
            len(frozenset().union(*(g.rooms for g in key))) <= MAX_SCIP_ROOMS
        if key not in self._seen or retry:
            self.checks += 1
            seconds = self._scip_seconds() if scip else 0.0
            verdict = level_one_verdict(self.problem, self.domain, key, time_limit=seconds,
                                        should_stop=self.should_stop)
            self._seen[key] = verdict
            self._prechecked.discard(key)
            if verdict is Verdict.UNDECIDED and not scip:
                self._prechecked.add(key)
            elif verdict is Verdict.UNDECIDED and seconds >= MIN_CHECK:
                self.undecided += 1
        return self._seen[key]

    def _scip_seconds(self) -> float:
        if self.undecided >= MAX_UNDECIDED:
            return 0.0
        left = self.deadline - time.monotonic()
        return min(left, max(CHECK_FLOOR, min(CHECK_CAP, left * CHECK_SHARE)))


def deletion_filter(
    items: Sequence[T], verdict_with: Callable[[list[T]], Verdict],
    out_of_time: Callable[[], bool],
) -> tuple[list[T], bool]:
    """The items that an infeasibility needs, out of `items` (all of them together are
    known infeasible; `verdict_with(subset)` judges a subset). Candidates are dropped
    a chunk at a time, the chunk doubling after each drop; a chunk the rest cannot do
    without is halved until the needed item is found, and the next chunk starts at one
    item (needed items often come together). Returns the kept items, in the order
    given, and whether each was shown needed (False when a check was undecided or time
    ran out)."""
    kept: list[T] = []
    proven = True
    candidates = list(items)
    chunk = max(1, len(candidates) // 2)
    # > 0: candidates[:needed_within] hold an item the others cannot do without,
    # shown by a feasible verdict when `needed_shown` (else by an undecided one).
    needed_within, needed_shown = 0, True
    while candidates:
        if needed_within == 1:
            kept.append(candidates.pop(0))
            proven = proven and needed_shown
            needed_within, chunk = 0, 1
            continue
        if out_of_time():
            left = set(kept) | set(candidates)
            return [x for x in items if x in left], False
        chunk = needed_within // 2 if needed_within else min(chunk, len(candidates))
        verdict = verdict_with(kept + candidates[chunk:])
        if verdict is Verdict.INFEASIBLE:
            del candidates[:chunk]
            needed_within = max(0, needed_within - chunk)
            chunk *= 2
        elif chunk == 1:
            kept.append(candidates.pop(0))
            proven = proven and verdict is Verdict.FEASIBLE
            needed_within = 0
        else:
            needed_within, needed_shown = chunk, verdict is Verdict.FEASIBLE
    needed = set(kept)
    return [x for x in items if x in needed], proven


def find_conflict(
    asked: Problem, domain: Domain, *, deadline: float, solved: Problem | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> ConflictSet | None:
    """A small set of the constraints of `asked` that cannot hold together, searched
    until `deadline` (a `time.monotonic()` value). `asked` must be known infeasible (a
    precheck finding, or SCIP's proof on level 1). `solved` is the problem as solved,
    with what require_connected added (derived from `asked` when not given). None when
    there was no time to check anything."""
    solved = solved if solved is not None else connection_demands(asked)
    groups = constraint_groups(solved, asked)
    checker = _Checker(solved, domain, deadline, should_stop)
    if find_impossibilities(solved, domain):
        # The prechecks' own proof first: shrinking with them alone costs no SCIP, and
        # SCIP is then asked only about the few constraints that proof rests on.
        groups, _ = _shrink(groups, checker.by_prechecks, checker.out_of_time)
    kept, minimal = _shrink(groups, checker, checker.out_of_time)
    if checker.checks == 0:
        return None
    items = describe_all(kept, solved, domain)
    shaped = bool(wings_wanted(restricted(solved, kept)))
    return ConflictSet(explanation=explanation(items, domain, minimal=minimal, shaped=shaped),
                       constraints=items, minimal=minimal)


def _shrink(
    groups: Sequence[Group], verdict_with: Callable[[list[Group]], Verdict],
    out_of_time: Callable[[], bool],
) -> tuple[list[Group], bool]:
    """`deletion_filter` over whole rooms (each with every group naming it), then over
    the groups of the rooms kept. Every group kept is tested on its own in the second
    pass, so whether the set is minimal is that pass's to say."""
    rooms, _ = deletion_filter(
        _rooms_in_drop_order(groups),
        lambda active: verdict_with([g for g in groups if g.rooms <= set(active)]),
        out_of_time,
    )
    within = [g for g in groups if g.rooms <= set(rooms)]
    within.sort(key=lambda g: (DROP_ORDER.index(g.kind), g.room or 0, g.index))
    return deletion_filter(within, verdict_with, out_of_time)


def _rooms_in_drop_order(groups: Sequence[Group]) -> list[int]:
    """The rooms the groups name, the least constrained first: those are the likeliest
    to stand apart from the conflict."""
    count: dict[int, int] = {}
    for g in groups:
        for i in g.rooms:
            count[i] = count.get(i, 0) + 1
    return sorted(count, key=lambda i: (count[i], i))


@dataclass(frozen=True)
class Diagnosis:
    """What a short look at a problem finds: the cheap impossibilities, whether SCIP
    found a level-1 layout (True), proved there is none (False) or neither (None),
    and when there is none, a conflict."""

    findings: list[str]
    feasible: bool | None
    conflict: ConflictSet | None


def diagnose(
    problem: Problem, *, time_limit: float, should_stop: Callable[[], bool] | None = None,
) -> Diagnosis:
    """The prechecks, then (when they find nothing) one level-1 check of the whole
    problem, then a conflict search if it is infeasible; all within `time_limit`.
    Soft constraints are left out: a layout may break them."""
    deadline = time.monotonic() + time_limit
    problem = hard_part(problem)
    solved = hard_part(connection_demands(problem))
    domain = make_domain(solved)
    findings = find_impossibilities(solved, domain)
    if findings:
        verdict = Verdict.INFEASIBLE
    else:
        verdict = level_one_verdict(
            solved, domain, constraint_groups(solved, problem), should_stop=should_stop,
            time_limit=time_limit * FIRST_CHECK_SHARE)
    conflict = None
    if verdict is Verdict.INFEASIBLE:
        conflict = find_conflict(problem, domain, deadline=deadline, solved=solved,
                                 should_stop=should_stop)
    feasible = {Verdict.FEASIBLE: True, Verdict.INFEASIBLE: False}.get(verdict)
    return Diagnosis(findings=findings, feasible=feasible, conflict=conflict)
