"""The problem a user sends: a building outline, rooms and their constraints (DESIGN.md §1).

Structural checks (types, signs, finiteness) are pydantic field constraints; the
cross-field checks (a valid outline, points inside the free area, known room ids)
run in `Problem._check_geometry_and_references` and raise one ``ValidationError``
whose entries name the offending field, e.g. ``("rooms", 2, "positions", 0)``.

A problem with a ``template`` (see `models.templates`) is validated as a
`TemplatedProblem` first and expanded into a plain one, so every `Problem` the
solver, the service or the client holds is the expanded form.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Annotated, Any, Literal, Self

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictInt,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError
from shapely.geometry import LineString, Polygon, box
from shapely.geometry import Point as ShapelyPoint
from shapely.geometry.base import BaseGeometry

#: Largest absolute coordinate or length we accept, in metres. Keeps big-M values sane.
MAX_COORDINATE = 1e5
#: Default cap on rooms per problem; pass ``context={"max_rooms": n}`` to change it.
DEFAULT_MAX_ROOMS = 400
#: The most rectangles a room may ask to start from (an L, T or U, or a room with a bay).
MAX_ROOM_RECTS = 4
#: Geometric tolerance in metres for "on the boundary" and similar tests.
TOLERANCE = 1e-6
#: Default aisle width between regions (metres): two people pass, a wheelchair turns.
DEFAULT_AISLE_WIDTH = 1.8
#: Narrowest and widest aisle accepted (metres).
MIN_AISLE_WIDTH = 0.8
MAX_AISLE_WIDTH = 10.0
#: Problems with more rooms than this are partitioned into regions by default.
DEFAULT_REGIONS_ABOVE = 40

Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Length = Annotated[float, Field(allow_inf_nan=False, ge=0, le=MAX_COORDINATE)]
PositiveLength = Annotated[float, Field(allow_inf_nan=False, gt=0, le=MAX_COORDINATE)]
Point = tuple[Coordinate, Coordinate]
#: [width, depth]: width along x (east), depth along y (north).
Size = tuple[Length, Length]
Compass = Literal["north", "south", "east", "west"]
#: The constraints of a room that may be soft (`Room.soft`, `Options.strict`).
SoftFamily = Literal["min_size", "max_size", "aspect_ratio", "positions", "boundary"]
SOFT_FAMILIES: tuple[SoftFamily, ...] = (
    "min_size", "max_size", "aspect_ratio", "positions", "boundary")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Obstacle(_Strict):
    """A rectangle no room may cover (stairs core, shaft, courtyard)."""

    x: Coordinate
    y: Coordinate
    width: PositiveLength
    depth: PositiveLength
    label: str = "obstacle"

    def to_box(self) -> Polygon:
        return box(self.x, self.y, self.x + self.width, self.y + self.depth)


class Room(_Strict):
    """One room to place, with its optional constraints."""

    id: Annotated[str, Field(min_length=1, max_length=100)]
    type: Annotated[str, Field(max_length=100)] = "room"
    min_size: Size | None = Field(None, description="[width, depth] lower bounds, C_size (Eq. 5)")
    max_size: Size | None = Field(None, description="[width, depth] upper bounds, C_size (Eq. 5)")
    target_size: Size | None = Field(None, description="[width, depth] wanted, E_size (Eq. 6)")
    aspect_ratio: tuple[PositiveLength, PositiveLength] | None = Field(
        None, description="[lo, hi], lo >= 1: long side / short side, C_ratio (Eq. 7)"
    )
    positions: Annotated[list[Point], Field(max_length=2)] = Field(
        default_factory=list, description="points the room must cover, C_pos (Eq. 8)"
    )
    boundary: list[Annotated[StrictInt, Field(ge=0)] | Compass] = Field(
        default_factory=list,
        description="exterior edges (indices or compass words); touch one, C_boundary (Eq. 9)",
    )
    shape: Literal["rectangle", "free"] = Field(
        "rectangle",
        description="'free': the room may be an L or T from the start (two rectangles "
        "sharing a wall), not only when a single rectangle cannot satisfy the constraints",
    )
    max_rects: Annotated[int, Field(ge=1, le=MAX_ROOM_RECTS)] | None = Field(
        None, description="rectangles the room may start from: 1 keeps it a rectangle; "
        "default 1, or 2 with shape 'free'",
    )
    soft: bool | list[SoftFamily] = Field(
        False, description="constraints of this room that may be violated at a cost "
        "(Weights.violation per metre of shortfall) when they cannot all hold: true for "
        "all of them, or a list of min_size, max_size, aspect_ratio, positions, boundary. "
        "With options.strict false every one of them is soft anyway",
    )

    def soft_families(self, strict: bool = True) -> frozenset[SoftFamily]:
        """The families of this room's constraints that are soft: all of them when the
        problem is not `strict` or the room says `soft: true`, else those it lists."""
        if not strict or self.soft is True:
            return frozenset(SOFT_FAMILIES)
        return frozenset(self.soft or ())

    @property
    def rectangles(self) -> int:
        """How many rectangles the room starts from at level 1 when it asks."""
        if self.max_rects is not None:
            return self.max_rects
        return 2 if self.shape == "free" else 1

    @model_validator(mode="after")
    def _check_bounds(self) -> Self:
        errors: list[InitErrorDetails] = []
        if self.min_size and self.max_size:
            for axis, name in enumerate(("width", "depth")):
                if self.min_size[axis] > self.max_size[axis]:
                    errors.append(
                        _error(
                            ("min_size", axis),
                            self.min_size[axis],
                            "min_above_max",
                            f"minimum {name} {self.min_size[axis]} exceeds maximum "
                            f"{self.max_size[axis]}",
                        )
                    )
        if self.aspect_ratio:
            lo, hi = self.aspect_ratio
            if lo < 1:
                errors.append(
                    _error(("aspect_ratio", 0), lo, "ratio_below_one", "lower ratio must be >= 1")
                )
            if lo > hi:
                errors.append(
                    _error(("aspect_ratio", 0), lo, "ratio_order", "lower ratio exceeds upper")
                )
        if errors:
            raise ValidationError.from_exception_data(type(self).__name__, errors)
        return self


class Adjacency(_Strict):
    """C_adj (Eq. 10): `a` shares a wall of at least `min_contact` metres with `b`,
    or, with `any_of`, with at least one of the listed rooms (Eq. 11 generalised)."""

    a: str
    b: str | None = None
    any_of: Annotated[list[str], Field(min_length=1)] | None = None
    min_contact: Length = 0.9
    soft: bool = Field(
        False, description="the contact may fall short, or the rooms stay apart, at a cost "
        "(Weights.violation per metre of missing contact or of gap between the walls) when "
        "it cannot hold; with options.strict false every adjacency is soft anyway",
    )

    @model_validator(mode="after")
    def _exactly_one_partner_field(self) -> Self:
        if (self.b is None) == (self.any_of is None):
            raise PydanticCustomError(
                "adjacency_partner", "give exactly one of 'b' and 'any_of'"
            )
        return self

    @property
    def partners(self) -> list[str]:
        return [self.b] if self.b is not None else list(self.any_of or [])


class Region(_Strict):
    """A group of rooms laid out as one block first (paper Sec. 5.3, large layouts).

    The regions are placed like rooms (with these optional constraints, meaning what
    they mean for a room), the gaps between them become aisles of `aisle_width`, and
    then each region's rooms are laid out inside what is left of it."""

    id: Annotated[str, Field(min_length=1, max_length=100)]
    rooms: Annotated[list[str], Field(min_length=1)] = Field(
        description="ids of the rooms in this region; a room belongs to at most one region")
    min_size: Size | None = Field(None, description="[width, depth] lower bounds of the region")
    max_size: Size | None = Field(None, description="[width, depth] upper bounds of the region")
    target_size: Size | None = Field(
        None, description="[width, depth] wanted; default: its rooms' share of the floor, "
        "aisles included")
    aspect_ratio: tuple[PositiveLength, PositiveLength] | None = Field(
        None, description="[lo, hi], lo >= 1: long side / short side of the region")
    positions: Annotated[list[Point], Field(max_length=2)] = Field(
        default_factory=list, description="points the region must cover")
    boundary: list[Annotated[StrictInt, Field(ge=0)] | Compass] = Field(
        default_factory=list,
        description="exterior edges (indices or compass words); the region touches one")


#: Default cost of a metre of shortfall of a soft constraint: see `Weights.violation`.
DEFAULT_VIOLATION_WEIGHT = 100.0


class Weights(_Strict):
    """lambda_cover and lambda_size of Eq. 12, and the cost of soft violations."""

    cover: Annotated[float, Field(ge=0, le=1e3, allow_inf_nan=False)] = 1.0
    size: Annotated[float, Field(ge=0, le=1e3, allow_inf_nan=False)] = 1.0
    violation: Annotated[float, Field(gt=0, le=1e5, allow_inf_nan=False)] = Field(
        DEFAULT_VIOLATION_WEIGHT,
        description="cost per metre of shortfall of a soft constraint, added to Eq. 12. "
        "The default 100 makes a metre of shortfall cost as much as 100 m² of uncovered "
        "floor, more than moving one wall of a room up to ~30 m wide can gain in Eq. 12 "
        "at unit weights, so the solver trades accuracy for compliance, not the reverse",
    )


class Options(_Strict):
    """How to run the solve."""

    time_limit: Annotated[float, Field(gt=0, le=86400, allow_inf_nan=False)] | None = Field(
        None, description="seconds for the whole job; default 5 s up to 20 rooms, then 0.25 s/room"
    )
    seed: Annotated[int, Field(ge=0, le=2**31 - 1)] = 0
    max_levels: Annotated[int, Field(ge=1, le=10)] = 4
    size_error_threshold: Annotated[float, Field(ge=0, allow_inf_nan=False)] = Field(
        0.5,
        description="a room whose relative size error exceeds this is refined (Sec. 5.3); "
        "relative size error = E_size of the room / |target|^2",
    )
    require_connected: bool = Field(
        False, description="every room must be reachable through doors from the entrance: "
        "the solver adds the adjacencies that guarantee it, then doors where walls allow; "
        "the report says if any room stays unreachable",
    )
    # Regions and aisles (large layouts, Sec. 5.3 end).
    regions_above: Annotated[int, Field(ge=0, le=10_000)] = Field(
        DEFAULT_REGIONS_ABOVE,
        description="a problem without `regions` and with more rooms than this is "
        "partitioned into regions automatically and solved through regions and aisles "
        "(with an entrance or not: without one the aisles reach the facade); 0 never "
        "partitions",
    )
    strict: bool = Field(
        True, description="false: every constraint that can be relaxed (sizes, aspect "
        "ratios, positions, boundary walls, adjacencies, and what require_connected adds) "
        "is soft, so an over-constrained problem gets the layout of least total shortfall "
        "instead of none; inside the outline, no overlap and obstacles stay hard. A layout "
        "meeting every constraint is always looked for first",
    )


#: Room types that open only onto these types by default (paper Sec. 5.4: a door
#: policy defined in advance); every other type may open onto any room.
DEFAULT_DOOR_POLICY: dict[str, list[str]] = {
    "bathroom": ["corridor", "hall", "bedroom", "foyer"],
    "wc": ["corridor", "hall", "foyer", "living"],
    "closet": ["bedroom", "corridor", "hall"],
    "storage": ["corridor", "hall", "kitchen", "foyer", "garage"],
}
#: Room types that are ends, not passages: no one reaches the hall through a bathroom.
DEFAULT_NO_PASSAGE = ["bathroom", "wc", "closet", "storage"]
#: Room types without windows by default.
DEFAULT_WINDOWLESS = ["storage", "closet", "wc", "stairs", "shaft", "lift", "laundry"]


class Openings(_Strict):
    """Doors and windows added to the layout (paper Sec. 5.4)."""

    door_width: Annotated[float, Field(gt=0, le=10, allow_inf_nan=False)] = Field(
        0.9, description="clear width of every door, metres")
    window_width: Annotated[float, Field(gt=0, le=20, allow_inf_nan=False)] = Field(
        1.2, description="width of every window, metres")
    window_spacing: Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)] = Field(
        3.0, description="one window per this many metres of exterior wall, evenly spaced")
    door_policy: dict[str, list[str]] = Field(
        default_factory=lambda: dict(DEFAULT_DOOR_POLICY),
        description="room type -> the room types it may have a door to ('*' for any); "
        "types not listed may open onto any room",
    )
    windowless: list[str] = Field(
        default_factory=lambda: list(DEFAULT_WINDOWLESS),
        description="room types that get no windows",
    )
    no_passage: list[str] = Field(
        default_factory=lambda: list(DEFAULT_NO_PASSAGE),
        description="room types one may enter but not walk through to another room",
    )

    def allows_door(self, type_a: str, type_b: str) -> bool:
        """Whether the door policy lets rooms of these types share a door (both ways)."""
        def one_way(own: str, other: str) -> bool:
            allowed = self.door_policy.get(own)
            return allowed is None or "*" in allowed or other in allowed

        return one_way(type_a, type_b) and one_way(type_b, type_a)


class ProblemFields(_Strict):
    """The fields every form of a problem shares. Each form (`Problem`, and
    `models.templates.TemplatedProblem`) declares what its rooms are; `rooms` is
    declared here only to keep its place in the field order."""

    name: Annotated[str, Field(max_length=200)] = "layout"
    boundary: Annotated[list[Point], Field(min_length=4, max_length=1000)]
    obstacles: Annotated[list[Obstacle], Field(max_length=1000)] = Field(default_factory=list)
    entrance: Point | None = None
    rooms: list[Any]
    adjacency: list[Adjacency] = Field(default_factory=list)
    weights: Weights = Field(default_factory=Weights)
    options: Options = Field(default_factory=Options)
    openings: Openings = Field(default_factory=Openings)
    regions: list[Region] | None = Field(
        None, description="groups of rooms laid out as blocks with aisles between them "
        "(Sec. 5.3, large layouts); rooms in no region form a region of their own "
        "('rest'); adjacency entries may name two regions (they face each other across "
        "an aisle), not rooms of two different regions")
    aisle_width: Annotated[
        float, Field(ge=MIN_AISLE_WIDTH, le=MAX_AISLE_WIDTH, allow_inf_nan=False)
    ] = Field(DEFAULT_AISLE_WIDTH, description="clear width of the aisles between regions, "
              "metres")

    @field_validator("boundary", mode="before")
    @classmethod
    def _drop_closing_vertex(cls, value: Any) -> Any:
        return open_ring(value)

    @field_validator("rooms", mode="before")
    @classmethod
    def _room_count_within_limit(cls, rooms: Any, info: ValidationInfo) -> Any:
        # Before the rooms are validated: a templated problem expands each of them.
        limit = (info.context or {}).get("max_rooms", DEFAULT_MAX_ROOMS)
        if isinstance(rooms, list) and len(rooms) > limit:
            raise PydanticCustomError(
                "too_many_rooms", "{count} rooms exceed the limit of {limit}",
                {"count": len(rooms), "limit": limit},
            )
        return rooms

    def outline(self) -> Polygon:
        """The boundary as a shapely polygon (not yet minus obstacles)."""
        return Polygon(self.boundary)

    def free_area(self) -> Polygon:
        """The outline minus the obstacles: where rooms may go."""
        free = self.outline()
        for obstacle in self.obstacles:
            free = free.difference(obstacle.to_box())
        return free


# --- Several storeys (issue 5, paper Fig. 11) -------------------------------------------


class Floor(_Strict):
    """One storey of a building of several: its own rooms and adjacencies, and where
    they go. Outline and obstacles default to the problem's top-level ones."""

    id: Annotated[str, Field(min_length=1, max_length=100)] = Field(
        description="unique among the floors; named by `vertical[].floors`")
    name: Annotated[str, Field(max_length=200)] | None = Field(
        None, description="shown on the plan; default the id")
    boundary: Annotated[list[Point], Field(min_length=4, max_length=1000)] | None = Field(
        None, description="this floor's outline (axis-aligned, as the top-level `boundary`); "
        "default the top-level `boundary`, the building's footprint")
    obstacles: Annotated[list[Obstacle], Field(max_length=1000)] | None = Field(
        None, description="rectangles no room of this floor may cover (voids, a light well); "
        "default the top-level `obstacles`")
    entrance: Point | None = Field(
        None, description="a point on this floor's outline; the top-level `entrance` "
        "belongs to the first floor")
    rooms: Annotated[list[Room], Field(max_length=DEFAULT_MAX_ROOMS)] = Field(
        default_factory=list, description="the rooms of this floor only; ids unique among "
        "them and the vertical rooms spanning the floor (another floor may reuse an id)")
    adjacency: list[Adjacency] = Field(
        default_factory=list, description="C_adj on this floor; may name its rooms and the "
        "vertical rooms spanning it")

    @field_validator("boundary", mode="before")
    @classmethod
    def _drop_closing_vertex(cls, value: Any) -> Any:
        return open_ring(value)


class VerticalRoom(Room):
    """A room through several floors (stairs, a lift, a shaft): the very same rectangles
    on every floor it spans. Its constraints are imposed on the floor that places it
    first; the others take the footprint as it is."""

    floors: Annotated[list[str], Field(max_length=100)] | None = Field(
        None, description="ids of the floors it spans, at least two; default every floor")


# --- end of several storeys -------------------------------------------------------------


class Problem(ProblemFields):
    """A layout request: the domain, the rooms and their constraints (DESIGN.md §1).

    Input with a ``template`` is a `models.templates.TemplatedProblem`; validating it
    as a `Problem` expands the template, and the result has no ``template``.

    A building of several storeys gives `floors` (and `vertical` rooms) instead of
    `rooms`; see `models.storeys`."""

    rooms: list[Room] = Field(
        default_factory=list, description="the rooms to place, at least one; with `floors`, "
        "omitted or empty (each floor has its own)")
    floors: Annotated[list[Floor], Field(min_length=1, max_length=100)] | None = Field(
        None, description="several storeys (paper Fig. 11): each floor its own rooms and "
        "adjacencies; the answer is one layout per floor (`Layout.floors`)")
    vertical: Annotated[list[VerticalRoom], Field(max_length=DEFAULT_MAX_ROOMS)] = Field(
        default_factory=list, description="with `floors`: rooms through several floors "
        "(stairs, lifts, shafts), the same footprint on every floor they span")

    @model_validator(mode="before")
    @classmethod
    def _expand_template(cls, data: Any, info: ValidationInfo) -> Any:
        if not isinstance(data, dict) or "template" not in data:
            return data
        if data["template"] is None:  # "template": null asks for nothing
            return {key: value for key, value in data.items() if key != "template"}
        # Imported here: the templates module builds on this one.
        from models.templates import TemplatedProblem, expand

        return expand(TemplatedProblem.model_validate(data, context=info.context))

    @model_validator(mode="after")
    def _check_geometry_and_references(self, info: ValidationInfo) -> Self:
        if self.floors is not None or self.vertical:
            # Imported here: the storeys module builds on this one.
            from models.storeys import storey_errors

            errors = storey_errors(
                self, (info.context or {}).get("max_rooms", DEFAULT_MAX_ROOMS))
            if errors:
                raise ValidationError.from_exception_data(type(self).__name__, errors)
            return self
        if not self.rooms:
            raise ValidationError.from_exception_data(type(self).__name__, [_error(
                ("rooms",), self.rooms, "too_short",
                "at least one room is needed (or `floors`, each with its rooms)")])
        errors = list(_boundary_errors(self.boundary))
        if not errors:
            errors += _placement_errors(self)
        errors += _reference_errors(self)
        if errors:
            raise ValidationError.from_exception_data(type(self).__name__, errors)
        return self

    @property
    def room_count(self) -> int:
        """The rooms to lay out: `rooms`, or with `floors` every floor's rooms and each
        vertical room once."""
        floors = self.floors or []
        return len(self.rooms) + sum(len(f.rooms) for f in floors) + len(self.vertical)

    def with_options(self, **changes: Any) -> Problem:
        """This problem with the given options changed, as the solver derives its own
        sub-problems (not validated again: the values are the solver's, not a user's)."""
        return self.model_copy(update={"options": self.options.model_copy(update=changes)})

    def room(self, room_id: str) -> Room:
        for room in self.rooms:
            if room.id == room_id:
                return room
        raise KeyError(room_id)


def open_ring(value: Any) -> Any:
    """A boundary without its repeated closing vertex: GeoJSON-style rings repeat the
    first vertex, and edge k must still run from vertex k."""
    if isinstance(value, list) and len(value) > 4 and value[0] == value[-1]:
        return value[:-1]
    return value


def _error(loc: tuple[str | int, ...], value: Any, kind: str, message: str) -> InitErrorDetails:
    return InitErrorDetails(
        type=PydanticCustomError(kind, message), loc=loc, input=value
    )


def _boundary_errors(boundary: list[tuple[float, float]]) -> Iterator[InitErrorDetails]:
    n = len(boundary)
    for k in range(n):
        (x0, y0), (x1, y1) = boundary[k], boundary[(k + 1) % n]
        if math.isclose(x0, x1, abs_tol=TOLERANCE) and math.isclose(y0, y1, abs_tol=TOLERANCE):
            yield _error(("boundary", k), boundary[k], "degenerate_edge",
                         f"edge {k} has zero length (vertex {k} repeats)")
        elif not (x0 == x1 or y0 == y1):
            yield _error(("boundary", k), boundary[k], "not_axis_aligned",
                         f"edge {k} from {boundary[k]} to {boundary[(k + 1) % n]} is not "
                         "axis-aligned")
    polygon = Polygon(boundary)
    if polygon.area <= TOLERANCE:
        yield _error(("boundary",), boundary, "degenerate_boundary", "the boundary has no area")
    elif not polygon.is_valid:
        yield _error(("boundary",), boundary, "self_intersecting",
                     "the boundary crosses or touches itself")


def _placement_errors(problem: Problem) -> list[InitErrorDetails]:
    errors: list[InitErrorDetails] = []
    outline = problem.outline()
    grown = outline.buffer(TOLERANCE, join_style="mitre")
    boxes = [o.to_box() for o in problem.obstacles]
    for i, (obstacle, shape) in enumerate(zip(problem.obstacles, boxes, strict=True)):
        if not grown.contains(shape):
            errors.append(_error(("obstacles", i), obstacle.model_dump(), "obstacle_outside",
                                 f"obstacle {i} is not inside the boundary"))
        for j in range(i):
            if shape.intersection(boxes[j]).area > TOLERANCE:
                errors.append(_error(("obstacles", i), obstacle.model_dump(), "obstacle_overlap",
                                     f"obstacle {i} overlaps obstacle {j}"))
    if problem.entrance is not None and outline.exterior.distance(
        ShapelyPoint(problem.entrance)
    ) > 1e-3:
        errors.append(_error(("entrance",), problem.entrance, "entrance_off_boundary",
                             "the entrance must lie on the boundary"))
    for r, room in enumerate(problem.rooms):
        for p, point in enumerate(room.positions):
            where = ShapelyPoint(point)
            if not grown.contains(where):
                errors.append(_error(("rooms", r, "positions", p), point, "point_outside",
                                     f"position {point} of room '{room.id}' is outside the "
                                     "boundary"))
            elif any(shape.buffer(-TOLERANCE).contains(where) for shape in boxes):
                errors.append(_error(("rooms", r, "positions", p), point, "point_in_obstacle",
                                     f"position {point} of room '{room.id}' is inside an "
                                     "obstacle"))
        for b, edge in enumerate(room.boundary):
            if isinstance(edge, int) and edge >= len(problem.boundary):
                errors.append(_error(("rooms", r, "boundary", b), edge, "unknown_edge",
                                     f"edge {edge} does not exist: the boundary has "
                                     f"{len(problem.boundary)} edges"))
    return errors


def _reference_errors(problem: Problem) -> list[InitErrorDetails]:
    errors: list[InitErrorDetails] = []
    seen: set[str] = set()
    for r, room in enumerate(problem.rooms):
        if room.id in seen:
            errors.append(_error(("rooms", r, "id"), room.id, "duplicate_id",
                                 f"room id '{room.id}' is used twice"))
        seen.add(room.id)
    region_ids = {region.id for region in problem.regions or []}
    for k, adjacency in enumerate(problem.adjacency):
        if adjacency.a not in seen and adjacency.a not in region_ids:
            errors.append(_error(("adjacency", k, "a"), adjacency.a, "unknown_room",
                                 f"unknown room id '{adjacency.a}'"))
        field = "b" if adjacency.b is not None else "any_of"
        for p, partner in enumerate(adjacency.partners):
            if partner not in seen and partner not in region_ids:
                loc: tuple[str | int, ...] = (
                    ("adjacency", k, "b") if field == "b" else ("adjacency", k, "any_of", p)
                )
                errors.append(_error(loc, partner, "unknown_room",
                                     f"unknown room id '{partner}'"))
    if problem.regions is not None:
        errors += _region_errors(problem, seen)
    return errors


def region_of_rooms(problem: ProblemFields) -> dict[str, str]:
    """Room id -> the id of its explicit region (rooms in none are left out)."""
    return {room_id: region.id for region in problem.regions or []
            for room_id in region.rooms}


def _region_errors(problem: Problem, room_ids: set[str]) -> list[InitErrorDetails]:
    """Regions name known rooms, each room at most once, ids distinct from rooms';
    adjacencies pair two rooms of one region or two regions, never across an aisle."""
    errors: list[InitErrorDetails] = []
    regions = problem.regions or []
    owner: dict[str, str] = {}
    region_ids: set[str] = set()
    for g, region in enumerate(regions):
        if region.id in region_ids or region.id in room_ids:
            errors.append(_error(("regions", g, "id"), region.id, "duplicate_id",
                                 f"region id '{region.id}' is used twice (by a region or "
                                 "a room)"))
        region_ids.add(region.id)
        for i, room_id in enumerate(region.rooms):
            if room_id not in room_ids:
                errors.append(_error(("regions", g, "rooms", i), room_id, "unknown_room",
                                     f"unknown room id '{room_id}'"))
            elif room_id in owner:
                errors.append(_error(("regions", g, "rooms", i), room_id, "room_in_two_regions",
                                     f"room '{room_id}' is already in region "
                                     f"'{owner[room_id]}'"))
            else:
                owner[room_id] = region.id
        for b, edge in enumerate(region.boundary):
            if isinstance(edge, int) and edge >= len(problem.boundary):
                errors.append(_error(("regions", g, "boundary", b), edge, "unknown_edge",
                                     f"edge {edge} does not exist: the boundary has "
                                     f"{len(problem.boundary)} edges"))
        grown = problem.outline().buffer(TOLERANCE, join_style="mitre")
        for p, point in enumerate(region.positions):
            if not grown.contains(ShapelyPoint(point)):
                errors.append(_error(("regions", g, "positions", p), point, "point_outside",
                                     f"position {point} of region '{region.id}' is outside "
                                     "the boundary"))
        if region.min_size and region.max_size and any(
                region.min_size[k] > region.max_size[k] for k in (0, 1)):
            errors.append(_error(("regions", g, "min_size"), region.min_size, "min_above_max",
                                 "minimum size exceeds maximum size"))
        if region.aspect_ratio and not 1 <= region.aspect_ratio[0] <= region.aspect_ratio[1]:
            errors.append(_error(("regions", g, "aspect_ratio"), region.aspect_ratio,
                                 "ratio_order", "ratios must satisfy 1 <= lo <= hi"))
    for k, adjacency in enumerate(problem.adjacency):
        names = [adjacency.a, *adjacency.partners]
        if all(n in region_ids for n in names):
            continue
        if any(n in region_ids for n in names):
            errors.append(_error(("adjacency", k), adjacency.model_dump(), "region_and_room",
                                 "an adjacency names either regions or rooms, not both"))
            continue
        # Rooms in no explicit region share the implicit one.
        homes = {owner.get(n) for n in names if n in room_ids}
        if len(homes) > 1:
            errors.append(_error(("adjacency", k), adjacency.model_dump(), "across_regions",
                                 "rooms of different regions cannot share a wall: an aisle "
                                 "runs between regions (constrain the regions instead)"))
    return errors


def inside_entrance(
    boundary: Sequence[Point], entrance: Point, free: BaseGeometry, inset: float
) -> tuple[float, float] | None:
    """The entrance moved `inset` metres into the floor, across the outline edge it lies
    on, so that a room covering the point has its door there; None where that point is
    not in `free` (the floor less obstacles)."""
    where = ShapelyPoint(entrance)
    n = len(boundary)
    edges = [(boundary[k], boundary[(k + 1) % n]) for k in range(n)]
    (x0, y0), (x1, y1) = min(edges, key=lambda e: LineString(e).distance(where))
    length = math.hypot(x1 - x0, y1 - y0)
    if length == 0:
        return None
    nx, ny = -(y1 - y0) / length, (x1 - x0) / length
    for sign in (1, -1):
        px, py = entrance[0] + sign * inset * nx, entrance[1] + sign * inset * ny
        if free.contains(ShapelyPoint(px, py)):
            return px, py
    return None
