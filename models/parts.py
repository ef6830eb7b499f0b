"""The parts of a problem (DESIGN.md §1): obstacles, rooms, adjacencies, regions, the
fields every form of a problem shares (`ProblemFields`), floors and vertical rooms, and
the fields of a plain problem (`PlainFields`: its rooms, or its floors and the vertical
rooms through them).

The forms of a problem (`models.problem.Problem`, `models.templates.TemplatedProblem`)
and the storeys (`models.storeys`) build on this module; it builds on `models.base`,
`models.checks` and `models.options` (the weights, options and openings a problem
carries).
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Self

from pydantic import (
    Field,
    StrictInt,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError
from shapely.geometry import Polygon, box

from .base import (
    DEFAULT_MAX_ROOMS,
    SOFT_FAMILIES,
    Compass,
    Coordinate,
    Length,
    Point,
    PositiveLength,
    Size,
    SoftFamily,
    StrictModel,
)
from .checks import field_error, open_ring
from .corridors import Corridors
from .options import Openings, Options, Weights

#: The most rectangles a room may ask to start from (an L, T or U, or a room with a bay).
MAX_ROOM_RECTS = 4
#: The most vertices a fixed room's polygon may have (`Room.fixed`).
MAX_FIXED_VERTICES = 100
#: Default aisle width between regions (metres): two people pass, a wheelchair turns.
DEFAULT_AISLE_WIDTH = 1.8
#: Degrees in a turn: `ProblemFields.north` is below it.
FULL_TURN = 360.0
#: Narrowest and widest aisle accepted (metres).
MIN_AISLE_WIDTH = 0.8
MAX_AISLE_WIDTH = 10.0
#: Longest obstacle label: a name, not a payload (each is stored with every job of a
#: batch and written into drawings).
MAX_LABEL = 100
#: A reference to a room by its id (ids are at most 100 characters).
RoomRef = Annotated[str, Field(max_length=100)]

class Obstacle(StrictModel):
    """A rectangle no room may cover (stairs core, shaft, courtyard)."""

    x: Coordinate
    y: Coordinate
    width: PositiveLength
    depth: PositiveLength
    label: Annotated[str, Field(max_length=MAX_LABEL)] = "obstacle"

    def to_box(self) -> Polygon:
        return box(self.x, self.y, self.x + self.width, self.y + self.depth)


class Room(StrictModel):
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
        None, description="the most rectangles the room's shape may have (default 3: an L "
        "or a T; 1 keeps it a rectangle); 2 or more also make it start as an L or T at "
        "level 1 (as shape 'free' does with 2)",
    )
    soft: bool | list[SoftFamily] = Field(
        False, description="constraints of this room that may be violated at a cost "
        "(Weights.violation per metre of shortfall) when they cannot all hold: true for "
        "all of them, or a list of min_size, max_size, aspect_ratio, positions, boundary. "
        "With options.strict false every one of them is soft anyway",
    )

    fixed: Annotated[
        list[Point], Field(min_length=4, max_length=MAX_FIXED_VERTICES)
    ] | None = Field(
        None, description="the polygon the room must be exactly ([x, y] vertices, "
        "axis-aligned edges, inside the outline, over no obstacle and no other fixed "
        "room): the room is placed there as given and the other rooms are laid out around "
        "it; its own constraints are still checked on that polygon, and adjacencies to it "
        "hold as to any room. A repeated closing vertex is dropped",
    )

    @field_validator("fixed", mode="before")
    @classmethod
    def _drop_fixed_closing_vertex(cls, value: Any) -> Any:
        return open_ring(value)

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
                        field_error(
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
                    field_error(("aspect_ratio", 0), lo, "ratio_below_one",
                                "lower ratio must be >= 1")
                )
            if lo > hi:
                errors.append(
                    field_error(("aspect_ratio", 0), lo, "ratio_order",
                                "lower ratio exceeds upper")
                )
        if errors:
            raise ValidationError.from_exception_data(type(self).__name__, errors)
        return self


class Adjacency(StrictModel):
    """C_adj (Eq. 10): `a` shares a wall of at least `min_contact` metres with `b`,
    or, with `any_of`, with at least one of the listed rooms (Eq. 11 generalised)."""

    a: RoomRef
    b: RoomRef | None = None
    any_of: Annotated[list[RoomRef], Field(min_length=1)] | None = None
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


class Region(StrictModel):
    """A group of rooms laid out as one block first (paper Sec. 5.3, large layouts).

    The regions are placed like rooms (with these optional constraints, meaning what
    they mean for a room), the gaps between them become aisles of `aisle_width`, and
    then each region's rooms are laid out inside what is left of it."""

    id: Annotated[str, Field(min_length=1, max_length=100)]
    rooms: Annotated[list[RoomRef], Field(min_length=1)] = Field(
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



class ProblemFields(StrictModel):
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
    corridors: Corridors | None = Field(
        None, description="the circulation the floor must provide (exits, width, travel "
        "distance, dead ends): a corridor network is planned for it and the rooms laid "
        "out around it, instead of aisles between regions")
    north: float = Field(
        0.0, description="where true north points on the plan: degrees clockwise from "
        "the plan's +y (0, the default: y grows north; 90: north is +x), 0 to 360. The "
        "compass words of `boundary` lists name the sides facing that north; the SVG's "
        "arrow, the GeoJSON on a map and the IFC's TrueNorth follow it")

    @field_validator("boundary", mode="before")
    @classmethod
    def _drop_closing_vertex(cls, value: Any) -> Any:
        return open_ring(value)

    @field_validator("north", mode="before")
    @classmethod
    def _north_is_a_bearing(cls, value: Any) -> Any:
        if isinstance(value, bool) or not isinstance(value, int | float) or not (
                math.isfinite(value) and 0 <= value < FULL_TURN):
            raise PydanticCustomError(
                "north_bearing", "north is the angle in degrees, clockwise from the plan's "
                "+y, at which true north points: a number from 0 to less than 360 (e.g. "
                "330 for north 30 degrees to the left of the plan's up), not {value}",
                {"value": repr(value)})
        return float(value)

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

# --- Several storeys (paper Fig. 11) ----------------------------------------------------


class Floor(StrictModel):
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

    floors: Annotated[list[RoomRef], Field(max_length=100)] | None = Field(
        None, description="ids of the floors it spans, at least two; default every floor")


class PlainFields(ProblemFields):
    """The fields of a plain problem, one without a template: its rooms, or its floors
    and the vertical rooms through them. `models.problem.Problem` adds the validation;
    `models.storeys` reads a building through these fields alone."""

    rooms: list[Room] = Field(
        default_factory=list, description="the rooms to place, at least one; with `floors`, "
        "omitted or empty (each floor has its own)")
    floors: Annotated[list[Floor], Field(min_length=1, max_length=100)] | None = Field(
        None, description="several storeys (paper Fig. 11): each floor its own rooms and "
        "adjacencies; the answer is one layout per floor (`Layout.floors`)")
    vertical: Annotated[list[VerticalRoom], Field(max_length=DEFAULT_MAX_ROOMS)] = Field(
        default_factory=list, description="with `floors`: rooms through several floors "
        "(stairs, lifts, shafts), the same footprint on every floor they span")


def region_of_rooms(problem: ProblemFields) -> dict[str, str]:
    """Room id -> the id of its explicit region (rooms in none are left out)."""
    return {room_id: region.id for region in problem.regions or []
            for room_id in region.rooms}
