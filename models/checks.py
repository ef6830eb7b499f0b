"""The checks and helpers the forms of a problem (`models.problem.Problem`,
`models.templates.TemplatedProblem`) and the storeys (`models.storeys`) share: a
validation error's entries, an outline's faults, a closed ring opened, the entrance
moved into the floor."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

from pydantic_core import InitErrorDetails, PydanticCustomError
from shapely.geometry import LineString, Polygon
from shapely.geometry import Point as ShapelyPoint
from shapely.geometry.base import BaseGeometry

from .base import TOLERANCE, Point


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
