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
domain area; we have no plans to learn from, so the table, in `models.template_rules`
with the rules that connect rooms by type, is set by hand, with its sources in
docs/templates.md): every length of the table is multiplied by one factor, chosen so
that the typical areas of the templated rooms add up to the free area they share. For
a given list of rooms that factor is proportional to the square root of the free area.
A room's minimum side never drops below its type's floor (a regulation or a fixture's
size); when the floors alone do not fit the free area the problem is refused rather
than left infeasible.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError, field_validator
from pydantic_core import InitErrorDetails
from shapely import affinity
from shapely.errors import GEOSException
from shapely.geometry import Polygon

from .base import MAX_COORDINATE, Compass
from .checks import field_error, inside_entrance
from .parts import ProblemFields, Room
from .template_rules import (
    GENERIC_TYPE,
    KNOWN_TYPES,
    RESIDENTIAL,
    TEMPLATES,
    RoomSpec,
    Template,
    default_adjacency,
    root_room,
    rounded,
    rounded_down,
    rounded_up,
)

#: The size tables and door rules are `models.template_rules`'; these stay importable
#: from here.
__all__ = [
    "GENERIC_TYPE",
    "KNOWN_TYPES",
    "RESIDENTIAL",
    "TEMPLATES",
    "RoomSketch",
    "RoomSpec",
    "Template",
    "TemplateName",
    "TemplatedProblem",
    "expand",
]

TemplateName = Literal["residential"]
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
#: The template fills in no aspect ratio for a room the user aims beyond this ratio.
MAX_RATIO = 100.0
#: A generated id keeps at most this much of the type, leaving room for "-123" within
#: the 100 characters an id may have.
MAX_ID_BASE = 90


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
                    errors.append(field_error(
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
    adjacency += default_adjacency(problem, template, ids, types)
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
    lows = [rounded(v) for v in lows]
    highs = [max(rounded(v), lows[axis]) for axis, v in enumerate(highs)]
    target = [min(max(rounded(v), lows[axis]), highs[axis]) for axis, v in enumerate(target)]
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
    ratio = [max(1.0, rounded_down(lo_ratio)), rounded_up(hi_ratio)]
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
        errors.append(field_error(
            ("rooms",), [room["id"] for room in rooms], "template_rooms_too_many",
            f"the {template.name} template's smallest sizes for these {len(rooms)} rooms "
            f"need {need:.1f} m², more than {MIN_AREA_SHARE:.0%} of the free area "
            f"({site.area:.1f} m²): use fewer or smaller rooms, or state their sizes"))
    for k in sized:
        if "min_size" in problem.rooms[k].model_fields_set:
            continue
        side = max(rooms[k]["min_size"])
        if not site.fits_square(side):
            errors.append(field_error(
                ("rooms", k), rooms[k]["id"], "template_room_does_not_fit",
                f"a {types[k]} needs at least {side:g} x {side:g} m under the "
                f"{template.name} template, which fits nowhere in the free area; state "
                "its min_size to allow less"))
    if errors:
        raise ValidationError.from_exception_data("TemplatedProblem", errors)


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


# The front door.


def _cover_entrance(problem: TemplatedProblem, template: Template, ids: Sequence[str],
                    types: Sequence[str], rooms: list[dict[str, Any]], site: _Site) -> None:
    """The room at the front door (`root_room`: the first foyer, hall or corridor, else the
    living room) covers a point just inside the entrance, so the door opens into it."""
    root = root_room(problem, template, types)
    if "positions" in problem.rooms[root].model_fields_set:
        return
    assert problem.entrance is not None
    point = inside_entrance(problem.boundary, problem.entrance, site.free, ENTRANCE_INSET)
    if point is not None:
        rooms[root]["positions"] = [[round(point[0], 3), round(point[1], 3)]]

