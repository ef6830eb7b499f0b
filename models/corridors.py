"""The corridors a floor must have (DESIGN.md §6): exits, width, how far anyone may walk
to an exit, how long a dead end may be, and what the network trades off. The solver turns
them into a corridor network (Peng et al., SIGGRAPH 2016) and lays the rooms out around
it; the checks here are the ones that need nothing but the problem's own geometry."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field
from pydantic_core import InitErrorDetails
from shapely.geometry import Point as ShapelyPoint
from shapely.geometry import Polygon

from .base import Length, Point, PositiveLength, StrictModel
from .checks import field_error

#: Narrowest and widest corridor accepted (metres): below 0.9 m no door opens onto it.
MIN_CORRIDOR_WIDTH = 0.9
MAX_CORRIDOR_WIDTH = 6.0
#: An exit may lie this far (metres) off the outline or an obstacle's side.
EXIT_TOLERANCE = 1e-3


class CorridorWeights(StrictModel):
    """lambda_L and lambda_D of the network's objective (Peng et al. Eq. 14)."""

    length: Annotated[float, Field(ge=0, le=1e6, allow_inf_nan=False)] = Field(
        1.0, description="weight of the corridors' total length"
    )
    travel: Annotated[float, Field(ge=0, le=1e6, allow_inf_nan=False)] = Field(
        1.0, description="weight of the walking distances to the exits"
    )


class Route(StrictModel):
    """A walk the corridors must offer between two places (Peng et al. Eq. 7-8, their
    point-to-point constraint): a reception and a lift lobby, two wings' stairs."""

    between: tuple[Point, Point] = Field(
        description="two points on the floor (inside the free area, or on the outline or "
        "an obstacle's side) the corridors must join"
    )
    max_walk: PositiveLength | None = Field(
        None,
        description="the longest walk, metres, along the corridors from one point to the "
        "other; null: the shortest way the planning grid offers, give or take two of its "
        "cells",
    )


class Corridors(StrictModel):
    """The circulation a floor must provide, by what it does (Peng et al. Sec. 3)."""

    exits: Annotated[list[Point], Field(min_length=1, max_length=20)] = Field(
        description="points on the outline (doors out) or on a side of an obstacle (a "
        "stair or lift core): the corridors reach every one"
    )
    width: Annotated[
        float, Field(ge=MIN_CORRIDOR_WIDTH, le=MAX_CORRIDOR_WIDTH, allow_inf_nan=False)
    ] = Field(1.8, description="clear width of the corridors, metres")
    max_travel: PositiveLength | None = Field(
        None,
        description="the longest walk, metres, from any room's door along the "
        "corridors to the nearest exit; null: not limited",
    )
    dead_ends: Length | None = Field(
        None,
        description="the longest dead end, metres (a corridor end from which only "
        "one way leads on); 0: none; null: not limited",
    )
    weights: CorridorWeights = Field(default_factory=CorridorWeights)
    rooms_open_onto_corridor: bool = Field(
        True, description="every room must touch a corridor (and gets a door onto it)"
    )
    routes: Annotated[list[Route], Field(max_length=10)] = Field(
        default_factory=list,
        description="walks the corridors must offer between given points (each point "
        "within half a corridor of one)",
    )


def corridor_errors(
    corridors: Corridors,
    outline: Polygon,
    free: Polygon,
    obstacles: list[Polygon],
    *,
    regions: bool,
    floors: bool,
) -> list[InitErrorDetails]:
    """Why `corridors` cannot hold on this floor: an exit neither on the outline nor on an
    obstacle's side, a width the floor cannot hold, and the forms they do not combine
    with yet (user regions, several floors)."""
    errors: list[InitErrorDetails] = []
    if floors:
        errors.append(
            field_error(
                ("corridors",),
                None,
                "corridors_with_floors",
                "corridors are for a single floor: a building of several "
                "floors does not take them yet",
            )
        )
        return errors
    if regions:
        errors.append(
            field_error(
                ("corridors",),
                None,
                "corridors_with_regions",
                "corridors replace the aisles between regions: give "
                "`corridors` or `regions`, not both",
            )
        )
    for k, exit_point in enumerate(corridors.exits):
        where = ShapelyPoint(exit_point)
        on_wall = outline.exterior.distance(where) <= EXIT_TOLERANCE or any(
            box.exterior.distance(where) <= EXIT_TOLERANCE for box in obstacles
        )
        if not on_wall or not free.buffer(EXIT_TOLERANCE).contains(where):
            errors.append(
                field_error(
                    ("corridors", "exits", k),
                    exit_point,
                    "exit_off_outline",
                    f"exit {list(exit_point)} is neither on the outline nor on a side of an "
                    "obstacle (a stair or lift core)",
                )
            )
    for k, route in enumerate(corridors.routes):
        for end, point in enumerate(route.between):
            if not free.buffer(EXIT_TOLERANCE).contains(ShapelyPoint(point)):
                errors.append(
                    field_error(
                        ("corridors", "routes", k, "between", end),
                        point,
                        "route_off_floor",
                        f"route point {list(point)} is not on the free floor (outside the "
                        "outline or inside an obstacle)",
                    )
                )
        (ax, ay), (bx, by) = route.between
        # Corridors run along x and y: no walk between the points is shorter than this.
        least = abs(ax - bx) + abs(ay - by)
        if route.max_walk is not None and route.max_walk < least - EXIT_TOLERANCE:
            errors.append(
                field_error(
                    ("corridors", "routes", k, "max_walk"),
                    route.max_walk,
                    "route_too_short",
                    f"no corridor walk between {list(route.between[0])} and "
                    f"{list(route.between[1])} is shorter than {least:g} m (corridors run "
                    f"along x and y), so max_walk {route.max_walk:g} m cannot hold",
                )
            )
    x0, y0, x1, y1 = free.bounds
    if corridors.width >= min(x1 - x0, y1 - y0):
        errors.append(
            field_error(
                ("corridors", "width"),
                corridors.width,
                "corridor_too_wide",
                f"a corridor {corridors.width} m wide does not fit a floor "
                f"{x1 - x0:g} x {y1 - y0:g} m with rooms beside it",
            )
        )
    return errors
