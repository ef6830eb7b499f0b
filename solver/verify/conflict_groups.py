"""The constraint groups a conflict is made of (a room's size, a pair's adjacency, ...), in
the order they are dropped and listed, and each as the user wrote it: its path in the
problem, the rooms, a sentence; and the explanation of the whole set."""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from enum import StrEnum

from floorplan.models import ConflictItem, Problem
from floorplan.solver.geometry import EPS, Domain, Edge, compass_words, edges_named


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


def listing_key(g: Group) -> tuple[bool, int, int, int]:
    """Rooms in the problem's order, then adjacencies; as a room lists its fields."""
    return (g.room is None, g.room or 0, LIST_ORDER.index(g.kind), g.index)


AXIS_WORDS = (("wide", "width"), ("deep", "depth"))
REQUIRE_CONNECTED = "options.require_connected"


def describe_all(groups: Collection[Group], problem: Problem,
                 domain: Domain) -> list[ConflictItem]:
    """The groups as conflict items, in the problem's order. A bound needed on both
    axes is one item (`rooms.2.min_size`): dropping it all frees the room as much as
    dropping either axis did."""
    items = []
    for g in sorted(groups, key=listing_key):
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
            sides = " or ".join(
                f"edge {e.index} ({'/'.join(sorted(compass_words(e, problem.north)))}, "
                f"{_m(_edge_length(e))} m)" for e in edges)
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
