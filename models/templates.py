"""Constraint templates (paper Sec. 5.4): from room types and the domain's area alone,
fill in each room's sizes, the adjacencies a dwelling needs and which rooms want an
exterior wall.

A problem that names a ``template`` is a `TemplatedProblem`: its rooms may be bare
type strings (``"bedroom"``) or room objects with only some fields, and an id may be
left out. `expand` turns it into the input of a plain `Problem`; validating a
templated problem as a `Problem` does this on the way, so the solver, the service and
the client only ever hold the expanded form. The expansion drops ``template``: the
expanded problem is complete, and a user who edits it (drops an adjacency, say) and
sends it again gets exactly what they wrote.

Whatever the user states wins. A room field given (even ``"boundary": []``) is kept
and the template's own values for the others are widened to agree with it; an
adjacency the user gives between two rooms replaces the template's for that pair.

Sizes (the paper regresses each type's width and depth on the square root of the
domain area; we have no plans to learn from, so the table below is set by hand, with
its sources in docs/templates.md): every length of the table is multiplied by one
factor, chosen so that the typical areas of the templated rooms add up to the free
area they share. For a given list of rooms that factor is proportional to the square
root of the free area. A room's minimum side never drops below its type's floor (a
regulation or a fixture's size); when the floors alone do not fit the free area the
problem is refused rather than left infeasible.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError, field_validator
from pydantic_core import InitErrorDetails, PydanticCustomError
from shapely import affinity
from shapely.errors import GEOSException
from shapely.geometry import Polygon

from models.problem import (
    MAX_COORDINATE,
    Compass,
    ProblemFields,
    Room,
    inside_entrance,
)

TemplateName = Literal["residential"]
#: The type of a room object that names none, and the row used for types a template
#: does not know (given as objects; a bare unknown string is an error).
GENERIC_TYPE = "room"
#: Every exterior edge: "touch any outside wall".
ALL_SIDES: list[Compass] = ["north", "south", "east", "west"]
#: The minimum side of a room, as a share of its scaled typical short side (above the
#: type's floor): the paper's band of plausible sizes, taken as roughly ±30 %.
MIN_SHARE = 0.7
#: The templated rooms' minimum areas may take at most this share of the free area;
#: the rest is the slack the layout needs to pack rectangles of different sizes.
MIN_AREA_SHARE = 0.8
#: When the user's own targets leave less than this share of the free area to the
#: templated rooms, the templated rooms are sized as if this share were left.
LEAST_SHARE_LEFT = 0.1
#: The exterior walls, less this share (corners, the front door), are what the rooms
#: asking for an exterior wall may use, counting each by its minimum side.
EXTERIOR_SHARE = 0.8
#: The room at the front door covers the point this far (metres) inside the entrance.
ENTRANCE_INSET = 0.3
#: A templated adjacency asks for a door's width plus this much wall either side of it:
#: a contact of exactly one door's width leaves the door no clearance from the corners
#: (solver/openings.py keeps 0.1 m), and rounding can then lose the door altogether.
DOOR_CLEARANCE = 0.1
#: At most this many rooms to choose from in a templated `any_of` (each is a binary
#: of Eq. 11 for the solver); the circulation hubs come first.
MAX_OPTIONS = 6
#: The template fills in no aspect ratio for a room the user aims beyond this ratio.
MAX_RATIO = 100.0
#: A generated id keeps at most this much of the type, leaving room for "-123" within
#: the 100 characters an id may have.
MAX_ID_BASE = 90
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


class RoomSketch(Room):
    """A room of a templated problem: a `Room` whose id may be left out and whose
    constraints left out are filled in by the template."""

    id: Annotated[str, Field(min_length=1, max_length=100)] | None = Field(  # type: ignore[assignment]
        None, description="left out: the room's type, numbered when the type repeats "
        "(bedroom-1, bedroom-2)")


def _rooms_schema(schema: dict[str, Any]) -> None:
    # A room is an object or, as a shorthand, just its type.
    schema["items"] = {"anyOf": [schema["items"], {"type": "string", "enum": list(KNOWN_TYPES)}]}


class TemplatedProblem(ProblemFields):
    """A problem whose rooms are filled in from their types by a template (paper
    Sec. 5.4). Validating it as a `Problem` expands it (see `expand`)."""

    rooms: Annotated[list[RoomSketch], Field(min_length=1, json_schema_extra=_rooms_schema)]
    template: TemplateName = Field(
        description="fill in sizes, adjacencies and exterior walls from the rooms' types "
        "and the free area; expanded on validation into a plain problem")

    @field_validator("rooms", mode="before")
    @classmethod
    def _types_as_rooms(cls, rooms: Any) -> Any:
        """A bare string is a room of that type; it must be a type the template knows."""
        if not isinstance(rooms, list):
            return rooms
        errors: list[InitErrorDetails] = []
        out: list[Any] = []
        for k, item in enumerate(rooms):
            if isinstance(item, str):
                if _canonical(item) not in KNOWN_TYPES:
                    errors.append(_error(
                        (k,), item, "unknown_room_type",
                        f"unknown room type '{item}'; known: {', '.join(KNOWN_TYPES)} (a room "
                        f"object such as {{\"type\": \"{item}\"}} takes any type, sized as "
                        f"a generic '{GENERIC_TYPE}')"))
                item = {"type": _canonical(item)}
            out.append(item)
        if errors:
            raise ValidationError.from_exception_data(cls.__name__, errors)
        return out


def expand(problem: TemplatedProblem) -> dict[str, Any]:
    """The plain problem (as `Problem` input) that `problem`'s template spells out.
    Raises a located ``ValidationError`` when the template's smallest rooms cannot fit."""
    template = TEMPLATES[problem.template]
    types = [_canonical(room.type) for room in problem.rooms]
    ids = _room_ids(problem.rooms, types)
    rooms: list[dict[str, Any]] = []
    for room, room_id, room_type in zip(problem.rooms, ids, types, strict=True):
        stated = room.model_dump(exclude_unset=True, exclude={"id", "type"})
        known = room_type in template.sizes
        rooms.append({"id": room_id, "type": room_type if known else room.type, **stated})
    site = _Site.of(problem)
    if site is not None:  # a broken outline is reported by Problem's own checks
        _fill_sizes(problem, template, types, rooms, site)
        _fill_exterior(problem, template, types, rooms, site)
    adjacency = [a.model_dump(exclude_unset=True) for a in problem.adjacency]
    adjacency += _default_adjacency(problem, template, ids, types)
    if site is not None and problem.entrance is not None:
        _cover_entrance(problem, template, ids, types, rooms, site)
    expanded = problem.model_dump(exclude_unset=True, exclude={"template", "rooms", "adjacency"})
    return {**expanded, "rooms": rooms, "adjacency": adjacency}


# Ids.


def _canonical(room_type: str) -> str:
    return room_type.strip().lower()


def _room_ids(rooms: Sequence[RoomSketch], types: Sequence[str]) -> list[str]:
    """The user's ids, and for the others the type, numbered from 1 when several rooms
    without ids share it; a name the user took is skipped."""
    taken = {room.id for room in rooms if room.id is not None}
    unnamed: dict[str, int] = {}
    for room, room_type in zip(rooms, types, strict=True):
        if room.id is None:
            unnamed[room_type] = unnamed.get(room_type, 0) + 1
    ids: list[str] = []
    counters: dict[str, int] = {}
    for room, room_type in zip(rooms, types, strict=True):
        if room.id is not None:
            ids.append(room.id)
            continue
        base = (room_type or GENERIC_TYPE)[:MAX_ID_BASE]
        if unnamed[room_type] == 1 and base not in taken:
            name = base
        else:
            counter = counters.get(room_type, 0)
            while True:
                counter += 1
                name = f"{base}-{counter}"
                if name not in taken:
                    break
            counters[room_type] = counter
        taken.add(name)
        ids.append(name)
    return ids


# The site: what the template needs of the outline.


@dataclass(frozen=True)
class _Site:
    free: Polygon
    area: float
    perimeter: float
    width: float
    depth: float

    @classmethod
    def of(cls, problem: TemplatedProblem) -> _Site | None:
        try:
            outline = problem.outline()
            if not outline.is_valid or outline.area <= 0:
                return None
            free = problem.free_area()
        except (GEOSException, ValueError):
            return None
        if free.is_empty or free.area <= 0:
            return None
        x0, y0, x1, y1 = outline.bounds
        return cls(free, free.area, outline.exterior.length, x1 - x0, y1 - y0)

    def fits_square(self, side: float) -> bool:
        """Whether a side x side square fits in the free area (erosion, as the solver's
        precheck tests it)."""
        if side <= 0:
            return True
        scaled = affinity.scale(self.free, xfact=1 / side, yfact=1 / side, origin=(0, 0))
        return not scaled.buffer(-0.5 + 1e-9, join_style="mitre").is_empty


# Sizes.


def _fill_sizes(problem: TemplatedProblem, template: Template, types: Sequence[str],
                rooms: list[dict[str, Any]], site: _Site) -> None:
    sketches = problem.rooms
    sized = [k for k, room in enumerate(sketches)
             if not {"min_size", "max_size", "target_size", "aspect_ratio"}
             <= room.model_fields_set]
    if not sized:
        return
    # The user's own targets keep their area; the templated rooms share the rest.
    claimed = sum(room.target_size[0] * room.target_size[1] for room in sketches
                  if room.target_size is not None and "target_size" in room.model_fields_set)
    left = max(site.area - claimed, LEAST_SHARE_LEFT * site.area)
    aimed = [k for k in sized if "target_size" not in sketches[k].model_fields_set]
    typical = sum(template.spec(types[k]).area for k in aimed or sized)
    factor = math.sqrt(left / typical)
    wide = site.width >= site.depth
    cap = (min(site.width, MAX_COORDINATE), min(site.depth, MAX_COORDINATE))
    for k in sized:
        rooms[k].update(_room_sizes(sketches[k], template.spec(types[k]), factor, wide, cap))
    _check_floors_fit(problem, template, types, rooms, sized, site)


def _room_sizes(room: RoomSketch, spec: RoomSpec, factor: float, wide: bool,
                cap: tuple[float, float]) -> dict[str, Any]:
    """The template's sizes for one room, made to agree with what the user stated."""
    if spec.elongated:  # the long side along the outline's longer axis
        long, short = spec.long * factor, spec.short * factor
        target = [long, short] if wide else [short, long]
    else:
        side = math.sqrt(spec.area) * factor
        target = [side, side]
    low = max(spec.floor, MIN_SHARE * spec.short * factor)
    high = spec.max_long * factor
    lo_ratio, hi_ratio = spec.ratio
    lows, highs = [low, low], [min(high, cap[0]), min(high, cap[1])]
    given = room.model_fields_set
    for axis in (0, 1):
        if room.min_size is not None and "min_size" in given:
            highs[axis] = max(highs[axis], room.min_size[axis])
            target[axis] = max(target[axis], room.min_size[axis])
        if room.max_size is not None and "max_size" in given:
            lows[axis] = min(lows[axis], room.max_size[axis])
            target[axis] = min(target[axis], room.max_size[axis])
        if room.target_size is not None and "target_size" in given:
            lows[axis] = min(lows[axis], room.target_size[axis])
            highs[axis] = max(highs[axis], room.target_size[axis])
        if len(room.positions) == 2:  # the room must reach both points
            spread = abs(room.positions[0][axis] - room.positions[1][axis])
            highs[axis] = max(highs[axis], spread)
        highs[axis] = max(highs[axis], lows[axis])
        target[axis] = min(max(target[axis], lows[axis]), highs[axis])
    lows = [_round(v) for v in lows]
    highs = [max(_round(v), lows[axis]) for axis, v in enumerate(highs)]
    target = [min(max(_round(v), lows[axis]), highs[axis]) for axis, v in enumerate(target)]
    mins = list(room.min_size) if room.min_size is not None and "min_size" in given else lows
    maxs = list(room.max_size) if room.max_size is not None and "max_size" in given else highs
    aim = (list(room.target_size) if room.target_size is not None and "target_size" in given
           else target)
    # Widen the ratio to admit the aimed size, and drop it if no allowed size meets it
    # (or the user aims at a sliver no ratio of ours describes).
    long_side, short_side = max(aim), min(aim)
    sane = long_side <= MAX_RATIO * short_side
    if sane and short_side > 0:
        lo_ratio = min(lo_ratio, long_side / short_side)
        hi_ratio = max(hi_ratio, long_side / short_side)
    ratio = [max(1.0, _round_down(lo_ratio)), _round_up(hi_ratio)]
    filled: dict[str, Any] = {}
    if "min_size" not in given:
        filled["min_size"] = mins
    if "max_size" not in given:
        filled["max_size"] = maxs
    if "target_size" not in given:
        filled["target_size"] = aim
    if "aspect_ratio" not in given and sane and _ratio_possible(ratio, mins, maxs):
        filled["aspect_ratio"] = ratio
    return filled


def _ratio_possible(ratio: Sequence[float], mins: Sequence[float],
                    maxs: Sequence[float]) -> bool:
    """Whether some size within the bounds has its ratio in range (as the precheck asks)."""
    lo, hi = ratio
    (wl, dl), (wh, dh) = mins, maxs
    wide = lo * dl <= wh and wl <= hi * dh
    tall = lo * wl <= dh and dl <= hi * wh
    return wide or tall


def _check_floors_fit(problem: TemplatedProblem, template: Template, types: Sequence[str],
                      rooms: list[dict[str, Any]], sized: Iterable[int], site: _Site) -> None:
    """Refuse a problem whose smallest rooms cannot fit: better a message naming the
    rooms than a problem the solver proves infeasible. With `options.strict` false the
    minimum sizes are soft and may give way, so nothing is refused."""
    if not problem.options.strict:
        return
    errors: list[InitErrorDetails] = []
    mins = [room["min_size"] for room in rooms if room.get("min_size") is not None]
    need = sum(width * depth for width, depth in mins)
    if need > MIN_AREA_SHARE * site.area:
        errors.append(_error(
            ("rooms",), [room["id"] for room in rooms], "template_rooms_too_many",
            f"the {template.name} template's smallest sizes for these {len(rooms)} rooms "
            f"need {need:.1f} m², more than {MIN_AREA_SHARE:.0%} of the free area "
            f"({site.area:.1f} m²): use fewer or smaller rooms, or state their sizes"))
    for k in sized:
        if "min_size" in problem.rooms[k].model_fields_set:
            continue
        side = max(rooms[k]["min_size"])
        if not site.fits_square(side):
            errors.append(_error(
                ("rooms", k), rooms[k]["id"], "template_room_does_not_fit",
                f"a {types[k]} needs at least {side:g} x {side:g} m under the "
                f"{template.name} template, which fits nowhere in the free area; state "
                "its min_size to allow less"))
    if errors:
        raise ValidationError.from_exception_data("TemplatedProblem", errors)


def _round(value: float) -> float:
    return round(value, DECIMALS)


def _round_up(value: float) -> float:
    return math.ceil(value * 10**DECIMALS - 1e-9) / 10**DECIMALS


def _round_down(value: float) -> float:
    return math.floor(value * 10**DECIMALS + 1e-9) / 10**DECIMALS


# Exterior walls.


def _fill_exterior(problem: TemplatedProblem, template: Template, types: Sequence[str],
                   rooms: list[dict[str, Any]], site: _Site) -> None:
    """Rooms whose type wants daylight touch an exterior wall, most wanted first, while
    the outline's perimeter has room for them."""
    budget = EXTERIOR_SHARE * site.perimeter
    for k in range(len(rooms)):
        if "boundary" in problem.rooms[k].model_fields_set and problem.rooms[k].boundary:
            budget -= min(rooms[k].get("min_size") or [0.0])
    wanting = sorted(
        (k for k in range(len(rooms))
         if template.spec(types[k]).exterior and "boundary" not in problem.rooms[k].model_fields_set
         and types[k] in template.sizes),
        key=lambda k: (template.spec(types[k]).exterior, k))
    for k in wanting:
        side = min(rooms[k].get("min_size") or [0.0])
        if side > budget:
            break
        rooms[k]["boundary"] = list(ALL_SIDES)
        budget -= side


# Adjacency.


def _hubs(template: Template, types: Sequence[str]) -> list[int]:
    """The rooms people walk through to reach others, as indices: the circulation
    types in the order given, then the common ones."""
    circulation = [k for k, t in enumerate(types) if t in template.circulation]
    common = [k for k, t in enumerate(types) if t in template.common]
    return circulation + common


def _root(problem: TemplatedProblem, template: Template, types: Sequence[str]) -> int:
    """The room at the front door: the first hub, else the first room one may walk
    through, else the first room."""
    hubs = _hubs(template, types)
    if hubs:
        return hubs[0]
    ends = problem.openings.no_passage
    return next((k for k, t in enumerate(types) if t not in ends), 0)


def _default_adjacency(problem: TemplatedProblem, template: Template, ids: Sequence[str],
                       types: Sequence[str]) -> list[dict[str, Any]]:
    """The template's adjacencies: its pairs (kitchen and dining, bedrooms and their
    bathrooms and closets), then one contact per room that is not yet reachable from
    the room at the front door through allowed doors."""
    network = _Network(problem, template, ids, types)
    for a, b in _residential_pairs(ids, types):
        network.pair(a, b)
    network.connect_all()
    return network.added


class _Network:
    """Adjacencies as a door graph: who can be reached from the root through doors the
    door policy allows, never through a room that is an end (a bathroom). Links are
    only ever added, so the reached set only grows, one walk from each new room."""

    def __init__(self, problem: TemplatedProblem, template: Template, ids: Sequence[str],
                 types: Sequence[str]) -> None:
        self.ids = list(ids)
        self.type_of = dict(zip(ids, types, strict=True))
        self.openings = problem.openings
        self.ends = {i for i in ids if self.type_of[i] in problem.openings.no_passage}
        self.contact = _round(problem.openings.door_width + 2 * DOOR_CLEARANCE)
        self.hubs = [self.ids[k] for k in _hubs(template, types)]
        self.root = self.ids[_root(problem, template, types)]
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


def _residential_pairs(ids: Sequence[str], types: Sequence[str]) -> list[tuple[str, str]]:
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


# The front door.


def _cover_entrance(problem: TemplatedProblem, template: Template, ids: Sequence[str],
                    types: Sequence[str], rooms: list[dict[str, Any]], site: _Site) -> None:
    """The room at the front door (`_root`: the first foyer, hall or corridor, else the
    living room) covers a point just inside the entrance, so the door opens into it."""
    root = _root(problem, template, types)
    if "positions" in problem.rooms[root].model_fields_set:
        return
    assert problem.entrance is not None
    point = inside_entrance(problem.boundary, problem.entrance, site.free, ENTRANCE_INSET)
    if point is not None:
        rooms[root]["positions"] = [[round(point[0], 3), round(point[1], 3)]]


def _error(loc: tuple[str | int, ...], value: Any, kind: str, message: str) -> InitErrorDetails:
    return InitErrorDetails(type=PydanticCustomError(kind, message), loc=loc, input=value)
