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

from models import ConflictItem, ConflictSet, Problem
from solver.geometry import EPS, Domain, Edge, edges_named, make_domain
from solver.heuristics.level_one import level_one_spec, wings_wanted
from solver.miqp.formulation import build_level
from solver.miqp.scip_run import LevelStatus, run_level
from solver.openings import connection_demands
from solver.soft import hard_part
from solver.verify.precheck import find_impossibilities

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
#: all rooms rarely settles anything in seconds (solve.py builds large first layouts
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
                 f"{room.id}.size{'>=' if least else '<='}{_m(w)}x{_m(d)}",
                 f"'{room.id}' must be {'at least' if least else 'at most'} {_m(w)} m wide "
                 f"and {_m(d)} m deep")


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
                f"{name}.{noun}{'>=' if least else '<='}{_m(bounds[g.index])}",
                f"'{name}' must be {'at least' if least else 'at most'} "
                f"{_m(bounds[g.index])} m {adjective}")
        case Kind.ASPECT_RATIO:
            assert room.aspect_ratio is not None
            lo, hi = room.aspect_ratio
            return _item(f"{path}.aspect_ratio", g.kind, [name],
                         f"{name}.aspect_ratio=[{_m(lo)}, {_m(hi)}]",
                         f"'{name}' must have its long side {_m(lo)} to {_m(hi)} times its "
                         "short side")
        case Kind.POSITION:
            x, y = room.positions[g.index]
            return _item(f"{path}.positions.{g.index}", g.kind, [name],
                         f"{name} covers ({_m(x)}, {_m(y)})",
                         f"'{name}' must cover the point ({_m(x)}, {_m(y)})")
        case Kind.ENTRANCE:
            x, y = room.positions[g.index]
            return _item(REQUIRE_CONNECTED, g.kind, [name],
                         f"{name} covers the entrance ({_m(x)}, {_m(y)})",
                         f"'{name}' must cover the entrance at ({_m(x)}, {_m(y)}) to be "
                         "the front-door room (require_connected)")
        case Kind.BOUNDARY:
            edges = edges_named(problem, domain.edges, room.boundary)
            sides = " or ".join(f"edge {e.index} ({e.facing}, {_m(_edge_length(e))} m)"
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
                     f"{together}>={_m(adj.min_contact)}",
                     f"'{adj.a}' and {whom} must share at least {_m(adj.min_contact)} m of "
                     "wall")
    return _item(REQUIRE_CONNECTED, g.kind, [adj.a, *partners],
                 f"{together}>={_m(adj.min_contact)} (require_connected)",
                 f"'{adj.a}' must share at least {_m(adj.min_contact)} m of wall with {whom} "
                 "for a door (require_connected)")


def _item(path: str, kind: Kind, rooms: list[str], constraint: str,
          phrase: str) -> ConflictItem:
    return ConflictItem(path=path, kind=kind.value, rooms=rooms, constraint=constraint,
                        phrase=phrase)


def _edge_length(edge: Edge) -> float:
    lo, hi = edge.span
    return hi - lo


def _m(value: float) -> str:
    """A length or coordinate for people: centimetres at most, no trailing zeros.

    >>> _m(4.425223), _m(3.0), _m(0.9), _m(-0.5), _m(-0.001)
    ('4.43', '3', '0.9', '-0.5', '0')
    """
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def explanation(items: Sequence[ConflictItem], domain: Domain, *, minimal: bool,
                shaped: bool = False) -> str:
    """The conflict in one sentence, with the outline's dimensions. It is judged on
    level 1, where a room is one rectangle unless it asks for more (`shaped`)."""
    box = domain.bbox
    where = f"the {_m(box.width)} x {_m(box.depth)} m outline"
    if domain.area < box.area - EPS:
        where += f" ({domain.area:.4g} m² free)"
    where += (" with each room one rectangle or the ones it asks for" if shaped
              else " with each room one rectangle")
    head = ("This constraint cannot hold" if len(items) == 1
            else f"These {len(items)} constraints cannot all hold")
    sentence = f"{head} in {where}: {'; '.join(item.phrase for item in items)}."
    if not minimal:
        sentence += " Not every check was settled in time, so a smaller set may exist."
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
    problem, then a conflict search if it is infeasible; all within `time_limit`.
    Soft constraints (issue 8) are left out: a layout may break them."""
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
