"""The problem a user sends: a building outline, rooms and their constraints (DESIGN.md §1).

Structural checks (types, signs, finiteness) are pydantic field constraints; the
cross-field checks (a valid outline, points inside the free area, known room ids)
run in `Problem._check_geometry_and_references` and raise one ``ValidationError``
whose entries name the offending field, e.g. ``("rooms", 2, "positions", 0)``.

A problem with a ``template`` (see `models.templates`) is validated as a
`TemplatedProblem` first and expanded into a plain one, so every `Problem` the
solver, the service or the client holds is the expanded form.

The building blocks of a problem (rooms, obstacles, floors, ...) are defined in
`models.parts`, on `models.base`, `models.checks` and `models.options` (weights,
options, openings); the templates and the storeys build on them too, and they are
importable from here as well.
"""

from __future__ import annotations

from typing import Any, Self

from pydantic import ValidationError, ValidationInfo, model_validator
from pydantic_core import InitErrorDetails
from shapely import STRtree
from shapely.geometry import Point as ShapelyPoint
from shapely.geometry import Polygon

from .base import (
    DEFAULT_MAX_ROOMS,
    MAX_COORDINATE,
    SOFT_FAMILIES,
    TOLERANCE,
    Compass,
    Coordinate,
    Length,
    Point,
    PositiveLength,
    Size,
    SoftFamily,
)
from .checks import boundary_errors, field_error, inside_entrance, open_ring
from .corridors import Corridors, CorridorWeights, corridor_errors
from .options import (
    DEFAULT_DOOR_POLICY,
    DEFAULT_NO_PASSAGE,
    DEFAULT_REGIONS_ABOVE,
    DEFAULT_VIOLATION_WEIGHT,
    DEFAULT_WINDOWLESS,
    MAX_VARIANTS,
    Openings,
    Options,
    Weights,
)
from .parts import (
    DEFAULT_AISLE_WIDTH,
    MAX_AISLE_WIDTH,
    MAX_ROOM_RECTS,
    MIN_AISLE_WIDTH,
    Adjacency,
    Floor,
    Obstacle,
    PlainFields,
    ProblemFields,
    Region,
    Room,
    VerticalRoom,
    region_of_rooms,
)
from .storeys import storey_errors
from .templates import TemplatedProblem, expand

#: `Problem`, and the building blocks it was defined with before `models.parts` and its
#: siblings held them: ``from models.problem import Room`` keeps working.
__all__ = [
    "DEFAULT_AISLE_WIDTH",
    "DEFAULT_DOOR_POLICY",
    "DEFAULT_MAX_ROOMS",
    "DEFAULT_NO_PASSAGE",
    "DEFAULT_REGIONS_ABOVE",
    "DEFAULT_VIOLATION_WEIGHT",
    "DEFAULT_WINDOWLESS",
    "MAX_AISLE_WIDTH",
    "MAX_COORDINATE",
    "MAX_ROOM_RECTS",
    "MAX_VARIANTS",
    "MIN_AISLE_WIDTH",
    "SOFT_FAMILIES",
    "TOLERANCE",
    "Adjacency",
    "Compass",
    "Coordinate",
    "CorridorWeights",
    "Corridors",
    "Floor",
    "Length",
    "Obstacle",
    "Openings",
    "Options",
    "Point",
    "PositiveLength",
    "Problem",
    "ProblemFields",
    "Region",
    "Room",
    "Size",
    "SoftFamily",
    "VerticalRoom",
    "Weights",
    "boundary_errors",
    "field_error",
    "inside_entrance",
    "open_ring",
    "region_of_rooms",
]


class Problem(PlainFields):
    """A layout request: the domain, the rooms and their constraints (DESIGN.md §1).

    Input with a ``template`` is a `models.templates.TemplatedProblem`; validating it
    as a `Problem` expands the template, and the result has no ``template``.

    A building of several storeys gives `floors` (and `vertical` rooms) instead of
    `rooms`; see `models.storeys`."""

    @model_validator(mode="before")
    @classmethod
    def _expand_template(cls, data: Any, info: ValidationInfo) -> Any:
        if not isinstance(data, dict) or "template" not in data:
            return data
        if data["template"] is None:  # "template": null asks for nothing
            return {key: value for key, value in data.items() if key != "template"}
        return expand(TemplatedProblem.model_validate(data, context=info.context))

    @model_validator(mode="after")
    def _check_geometry_and_references(self, info: ValidationInfo) -> Self:
        if self.floors is not None or self.vertical:
            errors = storey_errors(
                self, (info.context or {}).get("max_rooms", DEFAULT_MAX_ROOMS))
            errors += _storey_fixed_errors(self)
            if self.corridors is not None:
                errors += corridor_errors(self.corridors, self.outline(), self.free_area(),
                                          [], regions=False, floors=True)
            if self.options.start is not None:
                errors.append(field_error(("options", "start"),
                                          [room.id for room in self.options.start],
                                          "start_with_floors",
                                          "options.start is for a single floor: a building "
                                          "of several floors takes no warm start"))
            if errors:
                raise ValidationError.from_exception_data(type(self).__name__, errors)
            return self
        if not self.rooms:
            raise ValidationError.from_exception_data(type(self).__name__, [field_error(
                ("rooms",), self.rooms, "too_short",
                "at least one room is needed (or `floors`, each with its rooms)")])
        errors = list(boundary_errors(self.boundary))
        if not errors:
            errors += _placement_errors(self)
            errors += _fixed_errors(self)
            if self.corridors is not None:
                errors += corridor_errors(
                    self.corridors, self.outline(), self.free_area(),
                    [o.to_box() for o in self.obstacles], regions=self.regions is not None,
                    floors=False)
        errors += _reference_errors(self)
        errors += _start_errors(self)
        if errors:
            raise ValidationError.from_exception_data(type(self).__name__, errors)
        return self

    @property
    def room_count(self) -> int:
        """The rooms to lay out: `rooms`, or with `floors` every floor's rooms and each
        vertical room once."""
        floors = self.floors or []
        return len(self.rooms) + sum(len(f.rooms) for f in floors) + len(self.vertical)

    @property
    def by_regions(self) -> bool:
        """Whether the floor is laid out by regions and aisles (or corridors): it names
        regions, asks for corridors, or has more rooms than `options.regions_above` (0:
        never)."""
        above = self.options.regions_above
        return (self.regions is not None or self.corridors is not None
                or (above > 0 and len(self.rooms) > above))

    def with_options(self, **changes: Any) -> Problem:
        """This problem with the given options changed, as the solver derives its own
        sub-problems (not validated again: the values are the solver's, not a user's)."""
        return self.model_copy(update={"options": self.options.model_copy(update=changes)})

    def room(self, room_id: str) -> Room:
        for room in self.rooms:
            if room.id == room_id:
                return room
        raise KeyError(room_id)


def _placement_errors(problem: Problem) -> list[InitErrorDetails]:
    errors: list[InitErrorDetails] = []
    outline = problem.outline()
    grown = outline.buffer(TOLERANCE, join_style="mitre")
    boxes = [o.to_box() for o in problem.obstacles]
    # Spatial indexes, built once: pairs of obstacles and obstacles around a position are
    # looked up, not tried one by one (1,000 obstacles and 800 positions took seconds).
    tree = STRtree(boxes)
    inner = [shape.buffer(-TOLERANCE) for shape in boxes]
    inner_tree = STRtree(inner)
    for i, (obstacle, shape) in enumerate(zip(problem.obstacles, boxes, strict=True)):
        if not grown.contains(shape):
            errors.append(field_error(("obstacles", i), obstacle.model_dump(), "obstacle_outside",
                                      f"obstacle {i} is not inside the boundary"))
        for j in sorted(int(k) for k in tree.query(shape, predicate="intersects") if k < i):
            if shape.intersection(boxes[j]).area > TOLERANCE:
                errors.append(field_error(("obstacles", i), obstacle.model_dump(),
                                          "obstacle_overlap",
                                          f"obstacle {i} overlaps obstacle {j}"))
    if problem.entrance is not None and outline.exterior.distance(
        ShapelyPoint(problem.entrance)
    ) > 1e-3:
        errors.append(field_error(("entrance",), problem.entrance, "entrance_off_boundary",
                                  "the entrance must lie on the boundary"))
    for r, room in enumerate(problem.rooms):
        for p, point in enumerate(room.positions):
            where = ShapelyPoint(point)
            if not grown.contains(where):
                errors.append(field_error(("rooms", r, "positions", p), point, "point_outside",
                                          f"position {point} of room '{room.id}' is outside the "
                                          "boundary"))
            elif len(inner_tree.query(where, predicate="within")):
                errors.append(field_error(("rooms", r, "positions", p), point, "point_in_obstacle",
                                          f"position {point} of room '{room.id}' is inside an "
                                          "obstacle"))
        for b, edge in enumerate(room.boundary):
            if isinstance(edge, int) and edge >= len(problem.boundary):
                errors.append(field_error(("rooms", r, "boundary", b), edge, "unknown_edge",
                                          f"edge {edge} does not exist: the boundary has "
                                          f"{len(problem.boundary)} edges"))
    return errors


def _fixed_errors(problem: Problem) -> list[InitErrorDetails]:
    """Why a room's `fixed` polygon cannot be placed: an edge neither horizontal nor
    vertical (or of zero length), no area or a ring crossing itself, a part outside
    the outline, over an obstacle or over another fixed room; with `regions` (not
    supported yet) any fixed room. Each error names ``rooms.<r>.fixed``."""
    errors: list[InitErrorDetails] = []
    grown = problem.outline().buffer(TOLERANCE, join_style="mitre")
    obstacles = [o.to_box() for o in problem.obstacles]
    placed: list[tuple[str, Polygon]] = []
    for r, room in enumerate(problem.rooms):
        if room.fixed is None:
            continue
        loc: tuple[str | int, ...] = ("rooms", r, "fixed")
        if problem.regions is not None:
            errors.append(field_error(loc, room.fixed, "fixed_with_regions",
                                      f"room '{room.id}' is fixed: fixed rooms cannot be "
                                      "combined with `regions` yet"))
            continue
        shape_errors = list(boundary_errors(room.fixed))
        if shape_errors:
            for e in shape_errors:
                k = e["loc"][1:] if len(e["loc"]) > 1 else ()
                errors.append(field_error((*loc, *k), e["input"], f"fixed_{e['type'].type}",
                                          f"fixed polygon of room '{room.id}': "
                                          f"{e['type'].message()}"))
            continue
        polygon = Polygon(room.fixed)
        if not grown.contains(polygon):
            errors.append(field_error(loc, room.fixed, "fixed_outside",
                                      f"the fixed polygon of room '{room.id}' is not inside "
                                      "the boundary"))
        for i, obstacle in enumerate(obstacles):
            if polygon.intersection(obstacle).area > TOLERANCE:
                errors.append(field_error(loc, room.fixed, "fixed_over_obstacle",
                                          f"the fixed polygon of room '{room.id}' covers "
                                          f"obstacle {i}"))
        for other_id, other in placed:
            if polygon.intersection(other).area > TOLERANCE:
                errors.append(field_error(loc, room.fixed, "fixed_overlap",
                                          f"the fixed polygon of room '{room.id}' overlaps "
                                          f"fixed room '{other_id}'"))
        placed.append((room.id, polygon))
    return errors


def _storey_fixed_errors(problem: Problem) -> list[InitErrorDetails]:
    """Fixed rooms are not supported in buildings of several storeys yet: each is an
    error naming its field."""
    errors = [field_error(("floors", f, "rooms", r, "fixed"), room.fixed, "fixed_with_floors",
                          f"room '{room.id}' is fixed: fixed rooms are not supported with "
                          "`floors` yet")
              for f, floor in enumerate(problem.floors or [])
              for r, room in enumerate(floor.rooms) if room.fixed is not None]
    errors += [field_error(("vertical", v, "fixed"), room.fixed, "fixed_with_floors",
                           f"room '{room.id}' is fixed: fixed rooms are not supported with "
                           "`floors` yet")
               for v, room in enumerate(problem.vertical) if room.fixed is not None]
    return errors


def _start_errors(problem: Problem) -> list[InitErrorDetails]:
    """A warm start (`options.start`) names each room of the problem at most once, and
    is given to a floor laid out as one, or to an edit (some rooms fixed): a floor laid
    out by regions (`by_regions`) and nothing fixed is solved region by region, whose
    parts hold some of the rooms only, and a start naming the others would make the job
    fail after it was accepted."""
    errors: list[InitErrorDetails] = []
    start = problem.options.start
    if start and problem.by_regions and all(room.fixed is None for room in problem.rooms):
        return [field_error(
            ("options", "start"), [room.id for room in start], "start_with_regions",
            "options.start is for a floor laid out as one or an edit: this floor is laid "
            "out by regions (it names regions, or has more rooms than "
            f"options.regions_above = {problem.options.regions_above}) and fixes no room")]
    ids = {room.id for room in problem.rooms}
    seen: set[str] = set()
    for k, room in enumerate(problem.options.start or []):
        loc: tuple[str | int, ...] = ("options", "start", k, "id")
        if room.id not in ids:
            errors.append(field_error(loc, room.id, "unknown_room",
                                      f"options.start names unknown room id '{room.id}'"))
        elif room.id in seen:
            errors.append(field_error(loc, room.id, "duplicate_id",
                                      f"options.start gives room '{room.id}' twice"))
        seen.add(room.id)
    return errors


def _reference_errors(problem: Problem) -> list[InitErrorDetails]:
    errors: list[InitErrorDetails] = []
    seen: set[str] = set()
    for r, room in enumerate(problem.rooms):
        if room.id in seen:
            errors.append(field_error(("rooms", r, "id"), room.id, "duplicate_id",
                                      f"room id '{room.id}' is used twice"))
        seen.add(room.id)
    region_ids = {region.id for region in problem.regions or []}
    for k, adjacency in enumerate(problem.adjacency):
        if adjacency.a not in seen and adjacency.a not in region_ids:
            errors.append(field_error(("adjacency", k, "a"), adjacency.a, "unknown_room",
                                      f"unknown room id '{adjacency.a}'"))
        field = "b" if adjacency.b is not None else "any_of"
        for p, partner in enumerate(adjacency.partners):
            if partner not in seen and partner not in region_ids:
                loc: tuple[str | int, ...] = (
                    ("adjacency", k, "b") if field == "b" else ("adjacency", k, "any_of", p)
                )
                errors.append(field_error(loc, partner, "unknown_room",
                                          f"unknown room id '{partner}'"))
    if problem.regions is not None:
        errors += _region_errors(problem, seen)
    return errors



def _region_errors(problem: Problem, room_ids: set[str]) -> list[InitErrorDetails]:
    """Regions name known rooms, each room at most once, ids distinct from rooms';
    adjacencies pair two rooms of one region or two regions, never across an aisle."""
    errors: list[InitErrorDetails] = []
    regions = problem.regions or []
    # Grown once, not per region: a 1,000-vertex outline and 20,000 regions took 15 s.
    grown = problem.outline().buffer(TOLERANCE, join_style="mitre") if any(
        region.positions for region in regions) else None
    owner: dict[str, str] = {}
    region_ids: set[str] = set()
    for g, region in enumerate(regions):
        if region.id in region_ids or region.id in room_ids:
            errors.append(field_error(("regions", g, "id"), region.id, "duplicate_id",
                                      f"region id '{region.id}' is used twice (by a region or "
                                      "a room)"))
        region_ids.add(region.id)
        for i, room_id in enumerate(region.rooms):
            if room_id not in room_ids:
                errors.append(field_error(("regions", g, "rooms", i), room_id, "unknown_room",
                                          f"unknown room id '{room_id}'"))
            elif room_id in owner:
                errors.append(field_error(("regions", g, "rooms", i), room_id,
                                          "room_in_two_regions",
                                          f"room '{room_id}' is already in region "
                                          f"'{owner[room_id]}'"))
            else:
                owner[room_id] = region.id
        for b, edge in enumerate(region.boundary):
            if isinstance(edge, int) and edge >= len(problem.boundary):
                errors.append(field_error(("regions", g, "boundary", b), edge, "unknown_edge",
                                          f"edge {edge} does not exist: the boundary has "
                                          f"{len(problem.boundary)} edges"))
        for p, point in enumerate(region.positions):
            if grown is not None and not grown.contains(ShapelyPoint(point)):
                errors.append(field_error(("regions", g, "positions", p), point, "point_outside",
                                          f"position {point} of region '{region.id}' is outside "
                                          "the boundary"))
        if region.min_size and region.max_size and any(
                region.min_size[k] > region.max_size[k] for k in (0, 1)):
            errors.append(field_error(("regions", g, "min_size"), region.min_size, "min_above_max",
                                      "minimum size exceeds maximum size"))
        if region.aspect_ratio and not 1 <= region.aspect_ratio[0] <= region.aspect_ratio[1]:
            errors.append(field_error(("regions", g, "aspect_ratio"), region.aspect_ratio,
                                      "ratio_order", "ratios must satisfy 1 <= lo <= hi"))
    for k, adjacency in enumerate(problem.adjacency):
        names = [adjacency.a, *adjacency.partners]
        if all(n in region_ids for n in names):
            continue
        if any(n in region_ids for n in names):
            errors.append(field_error(("adjacency", k), adjacency.model_dump(), "region_and_room",
                                      "an adjacency names either regions or rooms, not both"))
            continue
        # Rooms in no explicit region share the implicit one.
        homes = {owner.get(n) for n in names if n in room_ids}
        if len(homes) > 1:
            errors.append(field_error(("adjacency", k), adjacency.model_dump(), "across_regions",
                                      "rooms of different regions cannot share a wall: an aisle "
                                      "runs between regions (constrain the regions instead)"))
    return errors

