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

Two exact speed-ups. Whole rooms go first, each with every group naming it: rooms far
from the conflict leave in a few checks and the group phase solves small models. And
candidates are tried in chunks that halve when a chunk holds a needed group, so k
needed groups out of n cost about k log(n/k) checks rather than n. A check that runs
out of time keeps its group, and the set is then reported as possibly not minimal.

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

from models import ConflictItem, ConflictSet, Problem
from solver.formulation import build_level
from solver.geometry import EPS, Domain, Edge, edges_named, make_domain
from solver.level_one import level_one_spec
from solver.openings import connection_demands
from solver.precheck import find_impossibilities
from solver.scip_run import LevelStatus, run_level

#: A SCIP check gets at least this many seconds while that much is left ...
CHECK_FLOOR = 0.5
#: ... and at most this share of the time left: one hard check must not take it all.
CHECK_SHARE = 0.25
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


class Kind(StrEnum):
    """What a group constrains; the `kind` of a `ConflictItem`."""

    MIN_SIZE = "min_size"
    MAX_SIZE = "max_size"
    ASPECT_RATIO = "aspect_ratio"
    POSITION = "position"
    BOUNDARY = "boundary"
    ADJACENCY = "adjacency"
    CONNECTION = "connection"  # an any_of adjacency require_connected added
    ENTRANCE = "entrance"  # the front-door room covering the entrance (require_connected)


#: Kinds in the order groups are tried for dropping: those seldom at the heart of a
#: conflict first, so that when several sets exist the one found blames the usual
#: culprits (sizes and boundary demands) rather than, say, a loose maximum.
DROP_ORDER: tuple[Kind, ...] = (
    Kind.MAX_SIZE, Kind.ASPECT_RATIO, Kind.ADJACENCY, Kind.CONNECTION, Kind.POSITION,
    Kind.ENTRANCE, Kind.BOUNDARY, Kind.MIN_SIZE,
)
#: Kinds in the order a room's constraints are listed, as in the problem's JSON.
LIST_ORDER: tuple[Kind, ...] = (
    Kind.MIN_SIZE, Kind.MAX_SIZE, Kind.ASPECT_RATIO, Kind.POSITION, Kind.ENTRANCE,
    Kind.BOUNDARY, Kind.ADJACENCY, Kind.CONNECTION,
)


@dataclass(frozen=True)
class Group:
    """One constraint of the request. `room` is its room's index in `problem.rooms`
    (None for an adjacency); `index` is the axis of a size bound, the point of a
    position, or the adjacency entry; `rooms` holds every room it names, by index."""

    kind: Kind
    room: int | None
    index: int
    rooms: frozenset[int]


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
    """Can every constraint in `groups` hold at once, each room one rectangle?"""
    if not groups:
        return Verdict.FEASIBLE
    sub = restricted(problem, groups)
    if find_impossibilities(sub, domain):
        return Verdict.INFEASIBLE
    if time_limit < MIN_CHECK:
        return Verdict.UNDECIDED
    lm = build_level(level_one_spec(sub, domain, window=None), feasibility=True)
    result = run_level(lm, time_limit=time_limit, should_stop=should_stop)
    if result.status is LevelStatus.INFEASIBLE:
        return Verdict.INFEASIBLE
    return Verdict.FEASIBLE if result.rects is not None else Verdict.UNDECIDED


@dataclass
class _Checker:
    """Level-1 checks within a deadline, each remembered."""

    problem: Problem
    domain: Domain
    deadline: float
    should_stop: Callable[[], bool] | None
    checks: int = 0
    _seen: dict[frozenset[Group], Verdict] = field(default_factory=dict)

    def out_of_time(self) -> bool:
        stopped = self.should_stop is not None and self.should_stop()
        return stopped or self.deadline - time.monotonic() < MIN_CHECK

    def __call__(self, groups: Collection[Group]) -> Verdict:
        key = frozenset(groups)
        if key not in self._seen:
            left = self.deadline - time.monotonic()
            self.checks += 1
            self._seen[key] = level_one_verdict(
                self.problem, self.domain, key, should_stop=self.should_stop,
                time_limit=min(left, max(CHECK_FLOOR, left * CHECK_SHARE)))
        return self._seen[key]


def deletion_filter(
    items: Sequence[T], verdict_with: Callable[[list[T]], Verdict],
    out_of_time: Callable[[], bool],
) -> tuple[list[T], bool]:
    """The items that an infeasibility needs, out of `items` (all of them together are
    known infeasible; `verdict_with(subset)` judges a subset). Candidates are dropped
    a chunk at a time; a chunk the rest cannot do without is halved until the needed
    item is found. Returns the kept items, in the order given, and whether each was
    shown needed (False when a check was undecided or time ran out)."""
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
            needed_within, chunk = 0, max(1, len(candidates) // 2)
            continue
        if out_of_time():
            left = set(kept) | set(candidates)
            return [x for x in items if x in left], False
        chunk = needed_within // 2 if needed_within else min(chunk, len(candidates))
        verdict = verdict_with(kept + candidates[chunk:])
        if verdict is Verdict.INFEASIBLE:
            del candidates[:chunk]
            needed_within = max(0, needed_within - chunk)
        elif chunk == 1:
            kept.append(candidates.pop(0))
            proven = proven and verdict is Verdict.FEASIBLE
            needed_within, chunk = 0, max(1, len(candidates) // 2)
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
    rooms, rooms_proven = deletion_filter(
        _rooms_in_drop_order(groups),
        lambda active: checker([g for g in groups if g.rooms <= set(active)]),
        checker.out_of_time,
    )
    within = [g for g in groups if g.rooms <= set(rooms)]
    within.sort(key=lambda g: (DROP_ORDER.index(g.kind), g.room or 0, g.index))
    kept, groups_proven = deletion_filter(within, checker, checker.out_of_time)
    if checker.checks == 0:
        return None
    items = describe_all(kept, solved, domain)
    minimal = rooms_proven and groups_proven
    return ConflictSet(explanation=explanation(items, domain, minimal=minimal),
                    constraints=items, minimal=minimal)


def _rooms_in_drop_order(groups: Sequence[Group]) -> list[int]:
    """The rooms the groups name, the least constrained first: those are the likeliest
    to stand apart from the conflict."""
    count: dict[int, int] = {}
    for g in groups:
        for i in g.rooms:
            count[i] = count.get(i, 0) + 1
    return sorted(count, key=lambda i: (count[i], i))


def _listing_key(g: Group) -> tuple[bool, int, int, int]:
    """Rooms in the problem's order, then adjacencies; as a room lists its fields."""
    return (g.room is None, g.room or 0, LIST_ORDER.index(g.kind), g.index)


# -- words ------------------------------------------------------------------------------


AXIS_WORDS = (("wide", "width"), ("deep", "depth"))
REQUIRE_CONNECTED = "options.require_connected"


def describe_all(groups: Collection[Group], problem: Problem,
                 domain: Domain) -> list[ConflictItem]:
    """The groups as conflict items, in the problem's order. A bound needed on both
    axes is one item (`rooms.2.min_size`): dropping it all frees the room as much as
    dropping either axis did."""
    items = []
    for g in sorted(groups, key=_listing_key):
        if g.kind in (Kind.MIN_SIZE, Kind.MAX_SIZE):
            other = Group(g.kind, g.room, 1 - g.index, g.rooms)
            if other in groups:
                if g.index == 0:
                    items.append(_describe_size(g, problem))
                continue
        items.append(describe(g, problem, domain))
    return items


def _describe_size(g: Group, problem: Problem) -> ConflictItem:
    """Both axes of a room's minimum (or maximum) size as one item."""
    assert g.room is not None
    room = problem.rooms[g.room]
    least = g.kind is Kind.MIN_SIZE
    bounds = room.min_size if least else room.max_size
    assert bounds is not None
    w, d = bounds
    return _item(f"rooms.{g.room}.{g.kind}", g.kind, [room.id],
                 f"{room.id}.size{'>=' if least else '<='}{w:g}x{d:g}",
                 f"'{room.id}' must be {'at least' if least else 'at most'} {w:g} m wide "
                 f"and {d:g} m deep")


def describe(g: Group, problem: Problem, domain: Domain) -> ConflictItem:
    """`g` as a path, a compact form and a phrase."""
    if g.room is None:
        return _describe_adjacency(g, problem)
    room = problem.rooms[g.room]
    name, path = room.id, f"rooms.{g.room}"
    match g.kind:
        case Kind.MIN_SIZE | Kind.MAX_SIZE:
            bounds = room.min_size if g.kind is Kind.MIN_SIZE else room.max_size
            assert bounds is not None
            adjective, noun = AXIS_WORDS[g.index]
            least = g.kind is Kind.MIN_SIZE
            return _item(
                f"{path}.{g.kind}.{g.index}", g.kind, [name],
                f"{name}.{noun}{'>=' if least else '<='}{bounds[g.index]:g}",
                f"'{name}' must be {'at least' if least else 'at most'} "
                f"{bounds[g.index]:g} m {adjective}")
        case Kind.ASPECT_RATIO:
            assert room.aspect_ratio is not None
            lo, hi = room.aspect_ratio
            return _item(f"{path}.aspect_ratio", g.kind, [name],
                         f"{name}.aspect_ratio=[{lo:g}, {hi:g}]",
                         f"'{name}' must have its long side {lo:g} to {hi:g} times its "
                         "short side")
        case Kind.POSITION:
            x, y = room.positions[g.index]
            return _item(f"{path}.positions.{g.index}", g.kind, [name],
                         f"{name} covers ({x:g}, {y:g})",
                         f"'{name}' must cover the point ({x:g}, {y:g})")
        case Kind.ENTRANCE:
            x, y = room.positions[g.index]
            return _item(REQUIRE_CONNECTED, g.kind, [name],
                         f"{name} covers the entrance ({x:g}, {y:g})",
                         f"'{name}' must cover the entrance at ({x:g}, {y:g}) to be "
                         "the front-door room (require_connected)")
        case Kind.BOUNDARY:
            edges = edges_named(problem, domain.edges, room.boundary)
            sides = " or ".join(f"edge {e.index} ({e.facing}, {_edge_length(e):g} m)"
                                for e in edges)
            return _item(f"{path}.boundary", g.kind, [name],
                         f"{name}.boundary={','.join(str(b) for b in room.boundary)}",
                         f"'{name}' must lie along {sides}")
    raise AssertionError(f"not a room's constraint: {g.kind}")


def _describe_adjacency(g: Group, problem: Problem) -> ConflictItem:
    adj = problem.adjacency[g.index]
    partners = adj.partners
    together = f"{adj.a}-{partners[0]}" if len(partners) == 1 else \
        f"{adj.a}-({'|'.join(partners)})"
    whom = " or ".join(f"'{p}'" for p in partners)
    if g.kind is Kind.ADJACENCY:
        return _item(f"adjacency.{g.index}", g.kind, [adj.a, *partners],
                     f"{together}>={adj.min_contact:g}",
                     f"'{adj.a}' and {whom} must share at least {adj.min_contact:g} m of "
                     "wall")
    return _item(REQUIRE_CONNECTED, g.kind, [adj.a, *partners],
                 f"{together}>={adj.min_contact:g} (require_connected)",
                 f"'{adj.a}' must share at least {adj.min_contact:g} m of wall with {whom} "
                 "for a door (require_connected)")


def _item(path: str, kind: Kind, rooms: list[str], constraint: str,
          phrase: str) -> ConflictItem:
    return ConflictItem(path=path, kind=kind.value, rooms=rooms, constraint=constraint,
                        phrase=phrase)


def _edge_length(edge: Edge) -> float:
    lo, hi = edge.span
    return round(hi - lo, 6)


def explanation(items: Sequence[ConflictItem], domain: Domain, *, minimal: bool) -> str:
    """The conflict in one sentence, with the outline's dimensions."""
    box = domain.bbox
    where = f"the {box.width:g} x {box.depth:g} m outline"
    if domain.area < box.area - EPS:
        where += f" ({domain.area:.4g} m² free)"
    head = ("This constraint cannot hold" if len(items) == 1
            else f"These {len(items)} constraints cannot all hold")
    sentence = f"{head} in {where}: {'; '.join(item.phrase for item in items)}."
    if not minimal:
        sentence += " Some checks ran out of time, so a smaller set may exist."
    return sentence


# -- a look before solving --------------------------------------------------------------


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
    problem, then a conflict search if it is infeasible; all within `time_limit`."""
    deadline = time.monotonic() + time_limit
    solved = connection_demands(problem)
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
