"""Buildings of several storeys (paper Fig. 11; docs/problem.md, "Several storeys"): how a
`Problem` with `floors` is read, and its validation.

Each floor is an ordinary single-floor problem: its own rooms plus the vertical rooms
spanning it, laid out in its own outline (the top-level one unless it has its own).
`floor_problem` builds it; validating the building validates every floor's problem
and reports each error at the field the user wrote (``floors.1.rooms.2.positions.0``,
``vertical.0.min_size``), so a user never sees the assembled problem's indices.
`floor_view` and `draft_floor` give one floor of a building's problem and of a draft
layout, for drawing, export and progress displays.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, TypeVar

from pydantic import ValidationError
from pydantic_core import InitErrorDetails
from shapely import affinity
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from .base import DEFAULT_MAX_ROOMS
from .checks import boundary_errors, field_error
from .layout import FloorLayout, Layout
from .parts import Floor, PlainFields, Room, VerticalRoom

Loc = tuple[str | int, ...]
#: `models.problem.Problem` is built on this module (its validator calls
#: `storey_errors`), so this module knows a problem by its fields (`PlainFields`) only;
#: the functions below that make a problem make one of their argument's class.
P = TypeVar("P", bound=PlainFields)


def spanned_floors(problem: PlainFields, vertical: VerticalRoom) -> list[str]:
    """The ids of the floors `vertical` spans, in the problem's floor order."""
    floors = problem.floors or []
    wanted = set(vertical.floors) if vertical.floors is not None else None
    return [f.id for f in floors if wanted is None or f.id in wanted]


def verticals_on(problem: PlainFields, floor_id: str) -> list[int]:
    """Indices into `problem.vertical` of the vertical rooms spanning floor `floor_id`."""
    return [j for j, v in enumerate(problem.vertical)
            if floor_id in spanned_floors(problem, v)]


def floor_data(problem: PlainFields, index: int) -> dict[str, Any]:
    """Floor `index` as the fields of a single-floor problem: its rooms, then the
    vertical rooms spanning it (as plain rooms), its adjacencies, its outline."""
    assert problem.floors is not None
    floor = problem.floors[index]
    verticals = [problem.vertical[j] for j in verticals_on(problem, floor.id)]
    entrance = floor.entrance if floor.entrance is not None else (
        problem.entrance if index == 0 else None)
    return {
        "name": floor_title(problem, floor),
        "boundary": floor.boundary if floor.boundary is not None else problem.boundary,
        "obstacles": floor.obstacles if floor.obstacles is not None else problem.obstacles,
        "entrance": entrance,
        "rooms": [*floor.rooms, *(plain_room(v) for v in verticals)],
        "adjacency": floor.adjacency,
        "weights": problem.weights,
        "options": problem.options,
        "openings": problem.openings,
        "north": problem.north,
    }


def floor_problem(problem: P, index: int) -> P:
    """Floor `index` of `problem` as an ordinary single-floor problem."""
    return type(problem).model_validate(floor_data(problem, index))


def floor_title(problem: PlainFields, floor: Floor) -> str:
    return f"{problem.name} - {floor.name or floor.id}"


def plain_room(vertical: VerticalRoom) -> Room:
    """A vertical room as the room it is on each floor it spans."""
    return Room.model_validate(vertical.model_dump(exclude={"floors"}))


def storey_errors(
    problem: PlainFields, max_rooms: int = DEFAULT_MAX_ROOMS
) -> list[InitErrorDetails]:
    """Every reason why `problem`'s floors and vertical rooms cannot be laid out, each
    naming the field as the user wrote it; `max_rooms` caps the building's rooms."""
    if problem.floors is None:
        return [field_error(("vertical",), [v.id for v in problem.vertical],
                            "vertical_without_floors", "vertical rooms need `floors` to span")]
    errors: list[InitErrorDetails] = []
    if problem.rooms:
        errors.append(field_error(("rooms",), [r.id for r in problem.rooms], "rooms_and_floors",
                                  "with `floors`, give each floor its rooms and leave the "
                                  "top-level `rooms` empty"))
    if problem.adjacency:
        errors.append(field_error(("adjacency",), len(problem.adjacency), "adjacency_and_floors",
                                  "with `floors`, adjacencies go in each floor's `adjacency`"))
    errors += boundary_errors(problem.boundary)
    errors += _identity_errors(problem)
    if errors:
        return errors  # the floors' problems would repeat these in other words
    total = sum(len(f.rooms) for f in problem.floors) + len(problem.vertical)
    if total > max_rooms:
        errors.append(field_error(("floors",), total, "too_many_rooms",
                                  f"{total} rooms exceed the limit of {max_rooms}"))
    seen: set[tuple[Loc, str]] = set()
    for index in range(len(problem.floors)):
        for loc, kind, message, value in _floor_problem_errors(problem, index):
            if (loc, kind) not in seen:  # a vertical room's error shows once, not per floor
                seen.add((loc, kind))
                errors.append(field_error(loc, value, kind, message))
    errors += _fit_errors(problem)
    return errors


def _identity_errors(problem: PlainFields) -> Iterator[InitErrorDetails]:
    """Floor ids unique, vertical ids unique, each vertical room on known floors, two
    at least."""
    assert problem.floors is not None
    ids: set[str] = set()
    for i, floor in enumerate(problem.floors):
        if floor.id in ids:
            yield field_error(("floors", i, "id"), floor.id, "duplicate_id",
                              f"floor id '{floor.id}' is used twice")
        ids.add(floor.id)
    vertical_ids: set[str] = set()
    for j, vertical in enumerate(problem.vertical):
        if vertical.id in vertical_ids:
            yield field_error(("vertical", j, "id"), vertical.id, "duplicate_id",
                              f"vertical room id '{vertical.id}' is used twice")
        vertical_ids.add(vertical.id)
        for k, floor_id in enumerate(vertical.floors or []):
            if floor_id not in ids:
                yield field_error(("vertical", j, "floors", k), floor_id, "unknown_floor",
                                  f"unknown floor id '{floor_id}'")
        spans = spanned_floors(problem, vertical)
        if len(spans) < 2 and all(f in ids for f in vertical.floors or []):
            yield field_error(("vertical", j, "floors"), vertical.floors, "single_floor",
                              f"vertical room '{vertical.id}' spans {len(spans)} floor(s); it "
                              "needs two at least (a room on one floor belongs in its `rooms`)")


def _floor_problem_errors(
    problem: PlainFields, index: int
) -> Iterator[tuple[Loc, str, str, Any]]:
    """The errors of floor `index`'s own problem, at the fields the user wrote."""
    data = floor_data(problem, index)
    try:
        type(problem).model_validate(data)
    except ValidationError as err:
        for e in err.errors(include_url=False):
            yield _user_loc(problem, index, tuple(e["loc"])), e["type"], e["msg"], e["input"]


def _user_loc(problem: PlainFields, index: int, loc: Loc) -> Loc:
    """A field of floor `index`'s assembled problem as the field the user wrote."""
    assert problem.floors is not None
    floor = problem.floors[index]
    if not loc:
        return ("floors", index)
    head, rest = loc[0], loc[1:]
    if head == "rooms" and rest and isinstance(rest[0], int):
        k = rest[0]
        if k < len(floor.rooms):
            return ("floors", index, "rooms", k, *rest[1:])
        return ("vertical", verticals_on(problem, floor.id)[k - len(floor.rooms)], *rest[1:])
    if head == "rooms":
        return ("floors", index, "rooms", *rest)
    if head == "adjacency":
        return ("floors", index, "adjacency", *rest)
    own = {"boundary": floor.boundary, "obstacles": floor.obstacles, "entrance": floor.entrance}
    if head in own and own[head] is not None:
        return ("floors", index, head, *rest)
    return loc  # the top-level field this floor inherits


def user_path(problem: PlainFields, floor_id: str, path: str) -> str:
    """A dotted path into floor `floor_id`'s assembled problem (as in an explained
    conflict) as the path of the field the user wrote."""
    assert problem.floors is not None
    index = [f.id for f in problem.floors].index(floor_id)
    loc = tuple(int(p) if p.isdigit() else p for p in path.split("."))
    return ".".join(str(p) for p in _user_loc(problem, index, loc))


def common_free_area(problem: PlainFields, floor_ids: list[str]) -> BaseGeometry:
    """Where a room spanning `floor_ids` may stand: inside every one of their outlines
    and on none of their obstacles."""
    assert problem.floors is not None
    area: BaseGeometry | None = None
    for floor in problem.floors:
        if floor.id not in floor_ids:
            continue
        free: BaseGeometry = Polygon(floor.boundary or problem.boundary)
        obstacles = floor.obstacles if floor.obstacles is not None else problem.obstacles
        for obstacle in obstacles:
            free = free.difference(obstacle.to_box())
        area = free if area is None else area.intersection(free)
    return area if area is not None else Polygon()


def _fit_errors(problem: PlainFields) -> list[InitErrorDetails]:
    """A vertical room whose minimum size fits nowhere in the area common to its floors
    (the erosion test of the solver's prechecks: with x scaled by 1/w and y by 1/d, the
    area eroded by half a unit is empty)."""
    errors = []
    for j, vertical in enumerate(problem.vertical):
        if not vertical.min_size or min(vertical.min_size) <= 0:
            continue
        w, d = vertical.min_size
        common = common_free_area(problem, spanned_floors(problem, vertical))
        scaled = affinity.scale(common, xfact=1 / w, yfact=1 / d, origin=(0, 0))
        if scaled.is_empty or scaled.buffer(-0.5 + 1e-9, join_style="mitre").is_empty:
            errors.append(field_error(("vertical", j, "min_size"), vertical.min_size,
                                      "fits_nowhere",
                                      f"vertical room '{vertical.id}' needs at least {w:g} x {d:g} "
                                      "m, which fits nowhere in the area common to its floors"))
    return errors


def floor_view(problem: P, floor_id: str) -> P:
    """Floor `floor_id` as a single-floor problem, for drawing and export."""
    assert problem.floors is not None
    index = [f.id for f in problem.floors].index(floor_id)
    return floor_problem(problem, index)


def draft_floor(problem: PlainFields, floor_id: str, draft: Layout) -> Layout:
    """An incumbent of floor `floor_id` (a single-floor draft) as a layout of the
    building, that floor alone, for progress displays."""
    assert problem.floors is not None
    floor = next(f for f in problem.floors if f.id == floor_id)
    return Layout(name=problem.name, report=draft.report, floors=[FloorLayout(
        id=floor.id, name=floor.name or floor.id, rooms=draft.rooms, report=draft.report)])
