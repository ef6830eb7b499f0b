"""How a problem is solved and what is added to its layout: the weights of Eq. 12 and
of soft violations (`Weights`), the run's options (`Options`, with the warm start of
an edit, `StartRoom`), and the doors and windows (`Openings`, with the default door
policy)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, field_validator

from .base import Coordinate, PositiveLength, StrictModel

#: The most design variants a job may ask for (`Options.variants`).
MAX_VARIANTS = 12
#: The most whole redraws a diverse solve that stops when good may make (`Options.redraws`).
MAX_REDRAWS = 5
#: A whole redraw's seed is the layout's plus this times the draw (`Options.redraws`, and
#: `floorplan batch` between solves: both draw the same sizes).
REDRAW_SEED_STEP = 1_000_003
#: The most rooms and the most rectangles per room a warm start may give
#: (`Options.start`).
MAX_START_ROOMS = 400
MAX_START_RECTS = 16
#: Problems with more rooms than this are partitioned into regions by default.
DEFAULT_REGIONS_ABOVE = 40
#: Default cost of a metre of shortfall of a soft constraint: see `Weights.violation`.
DEFAULT_VIOLATION_WEIGHT = 100.0


class Weights(StrictModel):
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


class StartRect(StrictModel):
    """A rectangle of a warm start: bottom-left corner, width along x, depth along y."""

    x: Coordinate
    y: Coordinate
    width: PositiveLength
    depth: PositiveLength


class StartRoom(StrictModel):
    """One room of a previous layout, for `Options.start`. A room of a layout
    (`Layout.rooms[i]`) is accepted as it is: its type, polygon, area and region are
    read past; the rectangles are the start."""

    id: Annotated[str, Field(min_length=1, max_length=100)]
    rectangles: Annotated[list[StartRect], Field(min_length=1, max_length=MAX_START_RECTS)]
    type: Annotated[str, Field(max_length=100)] | None = None
    polygon: list[Any] | None = None
    area: float | None = None
    region: Annotated[str, Field(max_length=100)] | None = None


class Options(StrictModel):
    """How to run the solve."""

    time_limit: Annotated[float, Field(gt=0, le=86400, allow_inf_nan=False)] | None = Field(
        None, description="seconds for the whole job, a ceiling; default 5 s up to 20 rooms, "
        "then 0.25 s/room (the paper's), under which a one-floor solve whose first layout "
        "comes late may take longer: until twice 5 s and 1.2 s more a room from 8 to 14 rooms "
        "(24.4 s at 14), twice the default from 49")
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
        "takes up to 2x the time limit on a single floor (3x in a building or with "
        "regions). Fewer come back when no more distinct ones are found in time",
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
        "the report measures Eq. 12 against the brief's own targets (batches turn it "
        "on)",
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
        "batch wants many good plans, not each one's best; batches turn it on); "
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


class Openings(StrictModel):
    """Doors and windows added to the layout (paper Sec. 5.4)."""

    door_width: Annotated[float, Field(gt=0, le=10, allow_inf_nan=False)] = Field(
        0.9, description="clear width of every door, metres")
    window_width: Annotated[float, Field(gt=0, le=20, allow_inf_nan=False)] = Field(
        1.2, description="width of every window, metres")
    window_spacing: Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)] = Field(
        3.0, description="one window per this many metres of exterior wall, evenly spaced")
    door_policy: Annotated[
        dict[Annotated[str, Field(max_length=100)],
             Annotated[list[Annotated[str, Field(max_length=100)]], Field(max_length=100)]],
        Field(max_length=100),
    ] = Field(
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
