"""What a constraint template knows (paper Sec. 5.4): its room-size table, and the rules
that connect rooms by type (which pairs share a wall, how every room is reached from
the front door). `models.templates` applies them to a problem; docs/templates.md gives
the sources of the table's figures.

Lengths are in metres; the template's lengths in the expanded problem are rounded to
centimetres (`rounded`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from .parts import ProblemFields

#: The type of a room object that names none, and the row used for types a template
#: does not know (given as objects; a bare unknown string is an error).
GENERIC_TYPE = "room"
#: A templated adjacency asks for a door's width plus this much wall either side of it:
#: a contact of exactly one door's width leaves the door no clearance from the corners
#: (solver/openings.py keeps 0.1 m), and rounding can then lose the door altogether.
DOOR_CLEARANCE = 0.1
#: At most this many rooms to choose from in a templated `any_of` (each is a binary
#: of Eq. 11 for the solver); the circulation hubs come first.
MAX_OPTIONS = 6
#: Lengths in the expanded problem are rounded to centimetres.
DECIMALS = 2


@dataclass(frozen=True)
class RoomSpec:
    """One row of a size table. Lengths in metres, at typical size (factor 1)."""

    floor: float
    """The shortest side any room of this type may have (not scaled)."""
    short: float
    """Typical short side."""
    long: float
    """Typical long side."""
    max_long: float
    """Longest side."""
    ratio: tuple[float, float]
    """Aspect ratio [lo, hi], long side over short side."""
    exterior: int = 0
    """Priority for an exterior wall: 0 none, then 1 first, 2 next, ..."""

    @property
    def elongated(self) -> bool:
        """Rooms that must be long and thin aim for their long side along the outline's
        longer axis; the others aim for a square of their typical area."""
        return self.ratio[0] > 1

    @property
    def area(self) -> float:
        return self.short * self.long


@dataclass(frozen=True)
class Template:
    """A room-size table and the rules that connect rooms by type."""

    name: str
    sizes: dict[str, RoomSpec]
    circulation: tuple[str, ...]
    """Types people walk through to reach rooms; the first one present takes the
    front door."""
    common: tuple[str, ...]
    """Types that also serve as a way through (an open-plan living room)."""

    def spec(self, room_type: str) -> RoomSpec:
        return self.sizes.get(room_type, self.sizes[GENERIC_TYPE])


# The residential table. Floors: England's Nationally Described Space Standard
# (bedroom), the International Residential Code (habitable rooms, hallways, stairs, wc),
# the ADA wheelchair turning circle (foyer, bathroom), the NKBA one-cook work aisle
# (kitchen), the London Plan (balcony). Typical and largest sizes are our own, set so
# that a two-bedroom flat adds up to about the 70 m² the NDSS asks of it.
# docs/templates.md gives every figure's source.
RESIDENTIAL = Template(
    name="residential",
    sizes={
        "living": RoomSpec(2.13, 4.2, 5.4, 8.0, (1.0, 2.2), exterior=1),
        "dining": RoomSpec(2.13, 3.2, 3.8, 6.0, (1.0, 2.0)),
        "kitchen": RoomSpec(1.8, 2.8, 3.6, 5.5, (1.0, 2.5)),
        "bedroom": RoomSpec(2.15, 3.3, 3.8, 5.5, (1.0, 1.8), exterior=2),
        "bathroom": RoomSpec(1.5, 2.2, 2.6, 3.8, (1.0, 2.2)),
        "wc": RoomSpec(0.8, 1.0, 1.6, 2.4, (1.0, 2.8)),
        "foyer": RoomSpec(1.5, 2.0, 2.6, 4.0, (1.0, 2.5)),
        "hall": RoomSpec(0.92, 1.8, 3.0, 5.5, (1.0, 3.5)),
        "corridor": RoomSpec(0.92, 1.2, 5.0, 12.0, (2.5, 10.0)),
        "study": RoomSpec(2.13, 2.8, 3.2, 4.5, (1.0, 2.0), exterior=3),
        "office": RoomSpec(2.13, 2.8, 3.2, 4.5, (1.0, 2.0), exterior=3),
        "storage": RoomSpec(0.9, 1.2, 1.8, 3.0, (1.0, 3.0)),
        "closet": RoomSpec(0.9, 1.4, 1.8, 3.0, (1.0, 2.5)),
        "laundry": RoomSpec(1.5, 1.8, 2.4, 3.5, (1.0, 2.5)),
        "balcony": RoomSpec(1.5, 1.6, 3.6, 7.0, (1.5, 5.0), exterior=1),
        "stairs": RoomSpec(0.92, 1.0, 4.0, 5.0, (2.0, 5.0)),
        "garage": RoomSpec(2.6, 3.0, 5.5, 7.0, (1.3, 2.5), exterior=1),
        GENERIC_TYPE: RoomSpec(2.0, 3.0, 3.5, 5.0, (1.0, 2.0)),
    },
    circulation=("foyer", "hall", "corridor"),
    common=("living",),
)

TEMPLATES: dict[str, Template] = {RESIDENTIAL.name: RESIDENTIAL}
#: Room types some template knows: what a bare string in `rooms` may be.
KNOWN_TYPES: tuple[str, ...] = tuple(sorted({t for tpl in TEMPLATES.values() for t in tpl.sizes}))


def rounded(value: float) -> float:
    """`value` to the centimetre."""
    return round(value, DECIMALS)


def rounded_up(value: float) -> float:
    """`value` up to the next centimetre (a hair above one stays on it)."""
    return math.ceil(value * 10**DECIMALS - 1e-9) / 10**DECIMALS


def rounded_down(value: float) -> float:
    """`value` down to the centimetre below (a hair below one stays on it)."""
    return math.floor(value * 10**DECIMALS + 1e-9) / 10**DECIMALS


# Adjacency.


def hub_rooms(template: Template, types: Sequence[str]) -> list[int]:
    """The rooms people walk through to reach others, as indices: the circulation
    types in the order given, then the common ones."""
    circulation = [k for k, t in enumerate(types) if t in template.circulation]
    common = [k for k, t in enumerate(types) if t in template.common]
    return circulation + common


def root_room(problem: ProblemFields, template: Template, types: Sequence[str]) -> int:
    """The room at the front door: the first hub, else the first room one may walk
    through, else the first room."""
    hubs = hub_rooms(template, types)
    if hubs:
        return hubs[0]
    ends = problem.openings.no_passage
    return next((k for k, t in enumerate(types) if t not in ends), 0)


def default_adjacency(problem: ProblemFields, template: Template, ids: Sequence[str],
                      types: Sequence[str]) -> list[dict[str, Any]]:
    """The template's adjacencies: its pairs (kitchen and dining, bedrooms and their
    bathrooms and closets), then one contact per room that is not yet reachable from
    the room at the front door through allowed doors."""
    network = Network(problem, template, ids, types)
    for a, b in residential_pairs(ids, types):
        network.pair(a, b)
    network.connect_all()
    return network.added


class Network:
    """Adjacencies as a door graph: who can be reached from the root through doors the
    door policy allows, never through a room that is an end (a bathroom). Links are
    only ever added, so the reached set only grows, one walk from each new room."""

    def __init__(self, problem: ProblemFields, template: Template, ids: Sequence[str],
                 types: Sequence[str]) -> None:
        self.ids = list(ids)
        self.type_of = dict(zip(ids, types, strict=True))
        self.openings = problem.openings
        self.ends = {i for i in ids if self.type_of[i] in problem.openings.no_passage}
        self.contact = rounded(problem.openings.door_width + 2 * DOOR_CLEARANCE)
        self.hubs = [self.ids[k] for k in hub_rooms(template, types)]
        self.root = self.ids[root_room(problem, template, types)]
        self.added: list[dict[str, Any]] = []
        #: Two rooms that must touch: a door between them, either way.
        self.doors: dict[str, list[str]] = {i: [] for i in ids}
        #: The user's `any_of`: its room is reached once all its options are.
        self.choices: list[tuple[str, list[str]]] = []
        self.user_pairs: set[frozenset[str]] = set()
        for adj in problem.adjacency:
            if adj.a not in self.type_of or not all(p in self.type_of for p in adj.partners):
                continue  # an unknown id: Problem's own checks report it
            self.user_pairs |= {frozenset((adj.a, p)) for p in adj.partners}
            if len(adj.partners) == 1:
                self._door(adj.a, adj.partners[0])
            else:
                self.choices.append((adj.a, adj.partners))
        self.reached: set[str] = set()
        self._reach([self.root])

    def allows(self, a: str, b: str) -> bool:
        """The door policy lets a and b share a door (both ways)."""
        return a != b and self.openings.allows_door(self.type_of[a], self.type_of[b])

    def _door(self, a: str, b: str) -> None:
        if self.allows(a, b):
            self.doors[a].append(b)
            self.doors[b].append(a)

    def _reach(self, start: Iterable[str]) -> None:
        """Mark `start` reached and walk on from it."""
        queue = list(start)
        self.reached.update(queue)
        while queue:
            while queue:
                here = queue.pop()
                if here in self.ends:
                    continue
                for there in self.doors[here]:
                    if there not in self.reached:
                        self.reached.add(there)
                        queue.append(there)
            for room, options in self.choices:
                if room not in self.reached and all(
                        p in self.reached and p not in self.ends and self.allows(room, p)
                        for p in options):
                    self.reached.add(room)
                    queue.append(room)

    def pair(self, a: str, b: str) -> None:
        if frozenset((a, b)) in self.user_pairs:
            return  # the user's own adjacency for this pair stands
        self._door(a, b)
        self.added.append({"a": a, "b": b, "min_contact": self.contact})
        self._reach([room for room in (a, b) if room in self.reached])

    def connect_all(self) -> None:
        """Hubs first, each to an earlier hub; then the rooms one walks through, then
        the ends, each to a hub (or, if the policy allows none, to a reachable room)."""
        for k, hub in enumerate(self.hubs):
            self.connect(hub, self.hubs[:k])
        others = [i for i in self.ids if i not in self.hubs]
        for room in [i for i in others if i not in self.ends] + [
                i for i in others if i in self.ends]:
            self.connect(room, self.hubs)

    def connect(self, room: str, candidates: Sequence[str]) -> None:
        if room in self.reached:
            return

        def usable(pool: Iterable[str]) -> list[str]:
            return [c for c in pool if c in self.reached and c not in self.ends
                    and self.allows(room, c)][:MAX_OPTIONS]

        options = usable(candidates) or usable(self.ids)
        if not options:
            return  # nothing it may open onto: the layout will say it is unreachable
        partners: dict[str, Any] = (
            {"b": options[0]} if len(options) == 1 else {"any_of": options})
        self.added.append({"a": room, **partners, "min_contact": self.contact})
        for option in options:  # it touches one of them; all are reached
            self.doors[option].append(room)
        self._reach([room])


def residential_pairs(ids: Sequence[str], types: Sequence[str]) -> list[tuple[str, str]]:
    """Kitchens with dining rooms (or, without one, the living room: open plan);
    bedrooms with their own bathrooms and closets, in the order given. With fewer
    bathrooms than bedrooms the last bathroom stays shared, off the circulation."""
    of = {t: [i for i, own in zip(ids, types, strict=True) if own == t] for t in set(types)}
    kitchens, dinings, livings = of.get("kitchen", []), of.get("dining", []), of.get("living", [])
    bedrooms, bathrooms, closets = of.get("bedroom", []), of.get("bathroom", []), of.get(
        "closet", [])
    pairs = list(zip(kitchens, dinings, strict=False))
    if not dinings and livings:
        pairs += [(kitchen, livings[0]) for kitchen in kitchens]
    en_suite = len(bathrooms) if len(bathrooms) >= len(bedrooms) else len(bathrooms) - 1
    pairs += list(zip(bedrooms, bathrooms[:max(en_suite, 0)], strict=False))
    pairs += list(zip(bedrooms, closets, strict=False))
    return pairs
