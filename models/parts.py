"""The building blocks of a problem (DESIGN.md §1): obstacles, rooms, adjacencies,
regions, weights, options, openings, floors and vertical rooms, the fields every form
of a problem shares (`ProblemFields`), and the checks and helpers that the forms of a
problem (`models.problem.Problem`, `models.templates.TemplatedProblem`) and the
storeys (`models.storeys`) share.

A leaf of the `models` package: it imports no other module of it, so that
`models.templates` and `models.storeys` build on it and `models.problem` on all three.
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
#: The most design variants a job may ask for (`Options.variants`).
MAX_VARIANTS = 12
#: The most whole redraws a diverse solve that stops when good may make (`Options.redraws`).
MAX_REDRAWS = 5
#: A whole redraw's seed is the layout's plus this times the draw (`Options.redraws`, and
#: `floorplan batch` between solves: both draw the same sizes).
REDRAW_SEED_STEP = 1_000_003
#: The most vertices a fixed room's polygon may have (`Room.fixed`).
MAX_FIXED_VERTICES = 100
#: The most rooms and the most rectangles per room a warm start may give
#: (`Options.start`).
MAX_START_ROOMS = 400
MAX_START_RECTS = 16
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


class StartRect(_Strict):
    """A rectangle of a warm start: bottom-left corner, width along x, depth along y."""

    x: Coordinate
    y: Coordinate
    width: PositiveLength
    depth: PositiveLength


class StartRoom(_Strict):
    """One room of a previous layout, for `Options.start`. A room of a layout
    (`Layout.rooms[i]`) is accepted as it is: its type, polygon, area and region are
    read past; the rectangles are the start."""

    id: Annotated[str, Field(min_length=1, max_length=100)]
    rectangles: Annotated[list[StartRect], Field(min_length=1, max_length=MAX_START_RECTS)]
    type: str | None = None
    polygon: list[Any] | None = None
    area: float | None = None
    region: str | None = None


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
    variants: Annotated[int, Field(ge=1, le=MAX_VARIANTS)] = Field(
        1, description="how many design variants to return (1-12): up to this many valid "
        "layouts whose topologies differ (the graph of rooms sharing at least 0.9 m of wall "
        "is not the same), ranked by Eq. 12, best first, in `Layout.variants`; the search "
        "takes up to 3x the time limit. Fewer come back when no more distinct ones are "
        "found in time",
    )
    start: Annotated[list[StartRoom], Field(max_length=MAX_START_ROOMS)] | None = Field(
        None, description="a previous layout as a warm start for the free rooms of an edit "
        "(rooms with `fixed` keep their polygon; the others start where the previous layout "
        "had them, with as many rectangles, when that still satisfies the constraints): the "
        "`rooms` of a layout as the service returned it, or an object mapping room ids to "
        "lists of rectangles ({x, y, width, depth}). Every id must be a room of the problem. "
        "Only a single floor takes a start (not `floors`); it never changes what is valid, "
        "only where the search begins",
    )
    diverse: bool = Field(
        False, description="different seeds give different plans: the search aims at "
        "target sizes drawn from the seed within each room's min_size..max_size, the first "
        "layout leans toward points the seed draws, in half the seeds one room starts as "
        "an L, and the level-1 improvement pulls each room slightly in a direction drawn "
        "from the seed; "
        "the report measures Eq. 12 against the brief's own targets (batches turn it on; "
        "issue 23)",
    )
    stop: Literal["stalled", "limit"] = Field(
        "stalled", description="when the solve ends: \"stalled\" (default) as soon as more "
        "time is unlikely to buy anything (SCIP proved the layout optimal, or the best "
        "covering layout's Eq. 12 has not improved by 0.5 % in a window of 30 % of the time "
        "spent, at least 0.25 s; docs/method.md, \"When a solve ends\"); \"limit\": use the "
        "whole time limit. time_limit is a ceiling either way",
    )
    stop_when_good: bool = Field(
        False, description="stop at the first layout that passes every hard constraint "
        "and covers 99 % of the floor, instead of improving Eq. 12 to the time limit (a "
        "batch wants many good plans, not each one's best; batches turn it on, issue 23); "
        "the report's termination is then interrupted. Single-floor problems only",
    )
    redraws: Annotated[int, Field(ge=0, le=MAX_REDRAWS)] = Field(
        0, description="with diverse and stop_when_good: a solve that ends without a good "
        "layout is laid out again whole under another draw of the seed, at most this many "
        "times (0-5); time_limit is the draws' total, each draw an equal share of what is "
        "left, and the report's solve_time counts them all (batches through the API set 2)",
    )
    strict: bool = Field(
        True, description="false: every constraint that can be relaxed (sizes, aspect "
        "ratios, positions, boundary walls, adjacencies, and what require_connected adds) "
        "is soft, so an over-constrained problem gets the layout of least total shortfall "
        "instead of none; inside the outline, no overlap and obstacles stay hard. A layout "
        "meeting every constraint is always looked for first",
    )

    @field_validator("start", mode="before")
    @classmethod
    def _start_as_rooms(cls, value: Any) -> Any:
        return start_rooms(value)


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


def start_rooms(value: Any) -> Any:
    """`Options.start` given as an object (room id -> rectangles) as the list of rooms
    it stands for; anything else as it is."""
    if isinstance(value, dict):
        return [{"id": room_id, "rectangles": rects} for room_id, rects in value.items()]
    return value


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


# --- Shared checks and helpers ----------------------------------------------------------


def open_ring(value: Any) -> Any:
    """A boundary without its repeated closing vertex: GeoJSON-style rings repeat the
    first vertex, and edge k must still run from vertex k."""
    if isinstance(value, list) and len(value) > 4 and value[0] == value[-1]:
        return value[:-1]
    return value


def field_error(
    loc: tuple[str | int, ...], value: Any, kind: str, message: str
) -> InitErrorDetails:
    """One entry of a ``ValidationError``: `message` about the field at `loc`, of error
    type `kind`."""
    return InitErrorDetails(
        type=PydanticCustomError(kind, message), loc=loc, input=value
    )


def boundary_errors(boundary: list[tuple[float, float]]) -> Iterator[InitErrorDetails]:
    """Why `boundary` is no outline: a zero-length or slanted edge, no area, or a ring
    that crosses or touches itself."""
    n = len(boundary)
    for k in range(n):
        (x0, y0), (x1, y1) = boundary[k], boundary[(k + 1) % n]
        if math.isclose(x0, x1, abs_tol=TOLERANCE) and math.isclose(y0, y1, abs_tol=TOLERANCE):
            yield field_error(("boundary", k), boundary[k], "degenerate_edge",
                              f"edge {k} has zero length (vertex {k} repeats)")
        elif not (x0 == x1 or y0 == y1):
            yield field_error(("boundary", k), boundary[k], "not_axis_aligned",
                              f"edge {k} from {boundary[k]} to {boundary[(k + 1) % n]} is not "
                              "axis-aligned")
    polygon = Polygon(boundary)
    if polygon.area <= TOLERANCE:
        yield field_error(("boundary",), boundary, "degenerate_boundary",
                          "the boundary has no area")
    elif not polygon.is_valid:
        yield field_error(("boundary",), boundary, "self_intersecting",
                          "the boundary crosses or touches itself")


def region_of_rooms(problem: ProblemFields) -> dict[str, str]:
    """Room id -> the id of its explicit region (rooms in none are left out)."""
    return {room_id: region.id for region in problem.regions or []
            for room_id in region.rooms}


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
