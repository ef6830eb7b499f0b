"""The layout a user gets back (DESIGN.md §2): rooms as polygons plus a checked report."""

from __future__ import annotations

from collections.abc import Sequence
from enum import StrEnum

from pydantic import BaseModel, ConfigDict, Field

Point = tuple[float, float]


class Termination(StrEnum):
    """Why the solve stopped."""

    OPTIMAL = "optimal"
    """SCIP proved the returned layout optimal for its model (the whole floor's MIQP,
    within a relative gap of 1e-3): `Report.bound` and `Report.gap` say how close."""
    TIME_LIMIT = "timelimit"
    """The time limit was reached; the best layout found so far is returned."""
    STALLED = "stalled"
    """Ended before the time limit because more time was unlikely to buy anything (the
    best covering layout stopped improving, `options.stop`), or every stage ended with
    a layout that no model proved optimal (heuristics, neighbourhoods, refinement levels:
    a local optimum, not a proven one)."""
    INFEASIBLE = "infeasible"
    """No layout satisfies the hard constraints (see `Report.infeasibility`)."""
    INTERRUPTED = "interrupted"
    """Stopped on request (`should_stop`); the best layout so far is returned."""
    NO_SOLUTION = "no_solution"
    """The time ran out before any layout was found; feasibility is unknown."""
    IN_PROGRESS = "in_progress"
    """An incumbent of a solve still running, shown as it is: not yet checked."""

    @classmethod
    def of_parts(cls, parts: Sequence[Termination], *, interrupted: bool) -> Termination:
        """The termination of a solve made of several (regions, floors): interrupted if
        it was; optimal when every part was; stalled when every part was optimal or
        stalled; else the time limit."""
        if interrupted:
            return cls.INTERRUPTED
        if all(t is cls.OPTIMAL for t in parts):
            return cls.OPTIMAL
        if all(t in (cls.OPTIMAL, cls.STALLED) for t in parts):
            return cls.STALLED
        return cls.TIME_LIMIT


class Rect(BaseModel):
    """An axis-aligned rectangle: bottom-left corner, width along x, depth along y."""

    model_config = ConfigDict(frozen=True)

    x: float
    y: float
    width: float
    depth: float


class RoomLayout(BaseModel):
    id: str
    type: str
    polygon: list[Point] = Field(description="counter-clockwise outline, the union of rectangles")
    rectangles: list[Rect]
    area: float
    region: str | None = Field(
        None, description="the region the room was laid out in (large layouts), else null")


class Aisle(BaseModel):
    """Circulation floor between regions (large layouts, Sec. 5.3): not a room, but
    part of the plan; it counts as covered floor."""

    id: str
    polygon: list[Point] = Field(description="counter-clockwise outline")
    rectangles: list[Rect] = Field(description="disjoint rectangles whose union is the aisle")
    area: float
    width: float = Field(description="the problem's aisle_width, metres")
    regions: list[str] = Field(default_factory=list,
                               description="the regions this aisle runs along")


class Corridor(BaseModel):
    """A corridor of the floor's circulation (`Problem.corridors`): not a room, covered
    floor like an aisle; doors onto it name it in `between`."""

    id: str
    polygon: list[Point] = Field(description="counter-clockwise outline")
    rectangles: list[Rect] = Field(description="disjoint rectangles whose union is it")
    area: float
    width: float = Field(description="the corridors' clear width, metres")


class Egress(BaseModel):
    """How the corridors serve the floor, measured on the final plan: walks along the
    corridor floor (a raster of the corridor polygons), not the planned network."""

    max_travel: float | None = Field(
        None, description="the longest walk, metres, from a room's door along the corridors "
        "to the nearest exit (null when no room has a door onto a corridor)")
    mean_travel: float | None = Field(None, description="the mean of those walks, metres")
    travel: dict[str, float] = Field(
        default_factory=dict, description="per room with a door onto a corridor, its walk")
    dead_ends: list[float] = Field(
        default_factory=list, description="the length of every dead end of the corridors, "
        "metres, longest first")
    corridor_area: float = Field(0.0, description="m²")
    corridor_share: float = Field(0.0, description="corridor area over the free floor, 0..1")
    rooms_without_access: list[str] = Field(
        default_factory=list, description="rooms with no door onto a corridor")
    unreached_exits: list[str] = Field(
        default_factory=list, description="exits no corridor reaches, as 'x,y'")
    routes: list[float | None] = Field(
        default_factory=list, description="per route of `corridors.routes`, in order, "
        "the walk between its points, metres (straight onto the nearest corridor floor at "
        "each end, along it between); null: no corridor joins them")


#: The `between` name of the world outside, for the front door.
OUTSIDE = "outside"


class Door(BaseModel):
    """A door in a wall; `between` names two rooms, or a room and "outside"."""

    between: tuple[str, str]
    segment: tuple[Point, Point]
    opens_into: str | None = Field(None, description="the room the leaf swings into")
    requested: bool = Field(
        True, description="false for a door added only to make a room reachable")


class Window(BaseModel):
    room: str
    segment: tuple[Point, Point]


class Circulation(BaseModel):
    """How rooms connect through doors (after Peng et al.): a graph walked from the
    entrance."""

    reachable: bool = Field(description="every room can be reached from the entrance")
    unreachable: list[str] = Field(default_factory=list)
    steps: dict[str, int] = Field(
        default_factory=dict, description="doors passed from outside to each room")
    furthest: int = Field(0, description="the most doors passed to reach a room")
    dead_ends: list[str] = Field(default_factory=list,
                                 description="rooms with a single door")


class ConstraintCheck(BaseModel):
    """One constraint of the request, verified on the final polygons."""

    kind: str = Field(description="inside, overlap, size, aspect_ratio, position, boundary, "
                      "adjacency or coverage; aisle and aisle_access with regions")
    rooms: list[str]
    satisfied: bool
    detail: str = ""
    soft: bool = Field(False, description="the constraint was soft (options.strict false, "
                       "or soft on its room or adjacency): a violation costs, but the "
                       "layout stays valid")
    shortfall: float = Field(
        0.0, description="how far a violated constraint is from holding, in metres (0 when "
        "it holds): size, the missing width or depth (or the excess over the maximum), "
        "both axes added; aspect_ratio, how much the long side exceeds hi x the short side "
        "(or falls short of lo x it); position, the distance from the point to the room "
        "along the farther axis; boundary, the distance from the room to the nearest named "
        "edge, along the farther axis; adjacency, the missing contact length, or the gap "
        "between the walls when larger (the best partner of an any_of)")
    floor: str | None = Field(
        None, description="in a layout of several storeys: the id of the floor the check "
        "belongs to (none for a `vertical` check, which spans floors)")


class ExtraRectangles(BaseModel):
    """A room laid out from more than one rectangle from level 1 on (an L or T shape)."""

    room: str
    rectangles: int = Field(description="rectangles the room started from")
    reason: str = Field(description="'asked' (shape or max_rects in the problem) or why the "
                        "solver made it of several rectangles (a single one was not enough, "
                        "or the search that found the layout started it as an L)")


class ConflictItem(BaseModel):
    """One of the user's constraints in a conflict (see `ConflictSet`)."""

    path: str = Field(
        description="where the constraint is in the problem, a dotted path as in validation "
        "errors: rooms.2.min_size.0, rooms.2.boundary, rooms.2.positions.0, adjacency.1; "
        "options.require_connected for a constraint that option added")
    kind: str = Field(
        description="min_size, max_size (one axis each), aspect_ratio, position, boundary, "
        "adjacency; connection and entrance for what require_connected added (a wall "
        "for a door, the front-door room covering the entrance); vertical in a building "
        "of several storeys: a vertical room held where another floor put it; fixed: a "
        "room held at its `fixed` polygon (path rooms.<r>.fixed)")
    rooms: list[str] = Field(description="ids of the rooms the constraint names")
    constraint: str = Field(
        description="compact form, e.g. kitchen.width>=4, kitchen.boundary=east, "
        "kitchen-dining>=0.9")
    phrase: str = Field(description="the constraint in words")


class ConflictSet(BaseModel):
    """A small set of the user's constraints that cannot all hold together: without
    any one of them the rest can (when `minimal`). Constraints outside the set are not
    to blame and may stay as they are."""

    explanation: str = Field(description="the conflict in one sentence, naming the rooms "
                             "and the outline's dimensions")
    constraints: list[ConflictItem]
    minimal: bool = Field(
        description="dropping any one member was shown to make the rest satisfiable; "
        "false when some check was not settled in time (the set still cannot hold, but "
        "a smaller one may exist)")


class Infeasibility(BaseModel):
    """Why no layout was returned."""

    reason: str
    findings: list[str] = Field(default_factory=list, description="cheap impossibilities")
    active_families: list[str] = Field(default_factory=list)
    relaxations_tried: list[str] = Field(default_factory=list)
    conflict: ConflictSet | None = Field(
        None, description="when the problem is infeasible: a small set of its constraints "
        "that cannot hold together, searched in the time the solve had left")


class VariantInfo(BaseModel):
    """Where a layout stands among the design variants of its job (`Options.variants`)."""

    index: int = Field(description="its place in `Layout.variants`, 0 = the best (the "
                       "layout itself)")
    seed: int = Field(description="the seed of the search that found it (options.seed of "
                      "an ordinary solve gives the same search again)")
    adjacencies: list[tuple[str, str]] = Field(
        default_factory=list, description="its topology: the pairs of rooms sharing at "
        "least 0.9 m of wall, each pair sorted, sorted ('<floor>/<room>' with floors)")
    difference: list[float] = Field(
        default_factory=list, description="per variant, in order: the share of "
        "adjacencies that differ between the two (pairs in one graph and not the other, "
        "over pairs in either; 0 with itself, > 0 between any two variants)")
    least_difference: float | None = Field(
        None, description="the smallest difference to another variant (null when alone)")


class Report(BaseModel):
    coverage: float = Field(description="covered share of the free area, 0..1")
    uncovered_area: float
    constraints: list[ConstraintCheck] = Field(default_factory=list)
    size_error: dict[str, float] = Field(
        default_factory=dict,
        description="per room with a target: (W-W*)^2 + (D-D*)^2 of its bounding box (Eq. 6)",
    )
    objective: float | None = None
    bound: float | None = Field(
        None, description="SCIP's dual bound on Eq. 12 for the model whose solution the "
        "layout is (the whole floor's MIQP); null when the layout is not a solution SCIP "
        "returned for such a model (it came from refinement levels or a heuristic)")
    gap: float | None = Field(
        None, description="(objective - bound) / max(|objective|, 1e-9), with `bound`; "
        "null without it")
    levels: int = 0
    solve_time: float = 0.0
    termination: Termination = Termination.OPTIMAL
    valid: bool = Field(True, description="every hard constraint holds on the polygons; "
                       "violated soft constraints (see `violations`) do not count")
    infeasibility: Infeasibility | None = None
    circulation: Circulation | None = Field(
        None, description="set when the problem has an entrance")
    relaxation: float | None = Field(
        None,
        description="the size window (fraction of each target, 0.1 = 90-110 %) in which the "
        "first layout was found (Sec. 5.4); null when the user's own bounds were needed",
    )
    extra_rectangles: list[ExtraRectangles] = Field(
        default_factory=list,
        description="rooms that started from several rectangles at level 1, and why",
    )
    violations: list[ConstraintCheck] = Field(
        default_factory=list,
        description="every soft constraint the layout violates, with its shortfall (also "
        "among `constraints`); `valid` stays true when these are the only failures",
    )
    egress: Egress | None = Field(
        None, description="with `corridors` in the problem: travel distances, dead ends and "
        "corridor area, measured on the plan")
    total_shortfall: float = Field(
        0.0, description="the sum of the violations' shortfalls, metres")
    variant: VariantInfo | None = Field(
        None, description="with options.variants above 1: which variant this is and how "
        "much its topology differs from the others")


class FloorLayout(BaseModel):
    """One storey of a layout of several (`Layout.floors`): the layout of the floor's
    rooms and the vertical rooms spanning it, with the floor's own report."""

    id: str = Field(description="the floor's id in the problem")
    name: str = Field(description="the floor's name, else its id")
    rooms: list[RoomLayout] = Field(default_factory=list)
    doors: list[Door] = Field(default_factory=list)
    windows: list[Window] = Field(default_factory=list)
    report: Report = Field(description="this floor's checks, coverage and circulation, as "
                           "for a single-floor layout")


class Layout(BaseModel):
    name: str = "layout"
    rooms: list[RoomLayout] = Field(default_factory=list)
    doors: list[Door] = Field(default_factory=list)
    windows: list[Window] = Field(default_factory=list)
    aisles: list[Aisle] = Field(
        default_factory=list, description="aisles between regions (large layouts); their "
        "doors name them in `between`")
    corridors: list[Corridor] = Field(
        default_factory=list, description="with `corridors` in the problem: the corridor "
        "polygons (covered floor, like aisles); their doors name them in `between`")
    report: Report
    floors: list[FloorLayout] | None = Field(
        None, description="for a problem with `floors`: one layout per floor, in the "
        "problem's order (the top-level rooms, doors and windows then stay empty and the "
        "top-level report sums the floors up)")
    variants: list[Layout] | None = Field(
        None, description="with options.variants above 1: the design variants, each a "
        "full layout with its own report (`report.variant` says how distinct), all valid, "
        "pairwise different in topology, ranked by Eq. 12 (report.objective), best first; "
        "the first is this layout itself (without `variants`). Null otherwise")

    @property
    def circulation_spaces(self) -> list[Aisle]:
        """The aisles and the corridors, drawn and exported alike as circulation floor."""
        return [*self.aisles, *(Aisle(id=c.id, polygon=c.polygon, rectangles=c.rectangles,
                                      area=c.area, width=c.width) for c in self.corridors)]

    @property
    def all_rooms(self) -> list[RoomLayout]:
        """Every placed room: the rooms, or with `floors` those of every floor (a vertical
        room once per floor it spans)."""
        if self.floors is None:
            return self.rooms
        return [room for floor in self.floors for room in floor.rooms]
