"""Layouts as GeoJSON (RFC 7946) for GIS and web maps. Without an origin the coordinates
are the problem's own frame (metres, x east, y north: the "local" profile of
docs/exports.md, which RFC 7946 section 4 leaves to an arrangement between the parties);
no `crs` member, which RFC 7946 removed. With an origin (latitude, longitude) the plan's
(0, 0) is put there, turned so that its true north (`Problem.north`; 0: +y) is due
north, and every coordinate becomes WGS84 longitude and latitude."""

from __future__ import annotations

import math
from typing import Any

from floorplan.models import OUTSIDE, Layout, Problem
from floorplan.models.storeys import floor_view
from floorplan.solver.export.floors import floor_layout

#: The WGS84 ellipsoid: semi-major axis (m) and first eccentricity squared.
WGS84_A = 6378137.0
WGS84_E2 = 6.69437999014e-3
#: Decimal places of a degree kept: 1e-8 degrees is about a millimetre.
DEGREE_DIGITS = 8


def to_geojson(problem: Problem, layout: Layout,
               origin: tuple[float, float] | None = None) -> dict[str, Any]:
    """`_local_geojson`, its coordinates in WGS84 longitude and latitude when `origin`
    (latitude, longitude of the plan's (0, 0)) is given."""
    collection = _local_geojson(problem, layout)
    if origin is not None:
        to_degrees = _degrees_from(*origin, north=problem.north)
        for feature in collection["features"]:
            geometry = feature["geometry"]
            geometry["coordinates"] = _mapped(geometry["coordinates"], to_degrees)
    return collection


def _degrees_from(lat0: float, lon0: float, north: float = 0.0) -> Any:
    """Local metres to (longitude, latitude) about the point (lat0, lon0): the plan
    turned so that true north, `north` degrees clockwise from its +y (`Problem.north`),
    is due north, then the ellipsoid's radii of curvature there (meridian M, prime
    vertical N), which are exact to a millimetre over the few hundred metres of a
    building."""
    phi = math.radians(lat0)
    w = 1.0 - WGS84_E2 * math.sin(phi) ** 2
    meridian = WGS84_A * (1.0 - WGS84_E2) / w ** 1.5
    prime = WGS84_A / math.sqrt(w)
    cos, sin = math.cos(math.radians(north)), math.sin(math.radians(north))

    def to_degrees(x: float, y: float) -> list[float]:
        east, north_m = x * cos - y * sin, x * sin + y * cos
        lon = lon0 + math.degrees(east / (prime * math.cos(phi)))
        lat = lat0 + math.degrees(north_m / meridian)
        return [round(lon, DEGREE_DIGITS), round(lat, DEGREE_DIGITS)]

    return to_degrees


def _mapped(coordinates: Any, to_degrees: Any) -> Any:
    """`coordinates` (a position, or lists of them nested) with each position mapped."""
    if coordinates and isinstance(coordinates[0], int | float):
        return to_degrees(*coordinates)
    return [_mapped(c, to_degrees) for c in coordinates]


def _local_geojson(problem: Problem, layout: Layout) -> dict[str, Any]:
    """One Feature per room (Polygon, counter-clockwise) with its id, type, area and
    size error (and region); aisles as Polygon features of kind "aisle", corridors of
    kind "corridor"; doors and windows as LineString features; the outline and
    obstacles as features of their own.
    In a building of several storeys, every feature of a floor has that floor's id as
    its `floor` property."""
    if layout.floors is not None and problem.floors is not None:
        features: list[dict[str, Any]] = []
        for floor in layout.floors:
            single = floor_layout(layout, floor.id)
            for feature in _local_geojson(floor_view(problem, floor.id), single)["features"]:
                feature["properties"]["floor"] = floor.id
                features.append(feature)
        collection = _local_geojson(problem, Layout(name=layout.name, report=layout.report))
        collection["features"] = features
        return collection
    features = [
        _feature("Polygon", [_ring(problem.boundary)], kind="outline", name=problem.name),
    ]
    for o in problem.obstacles:
        corners = [(o.x, o.y), (o.x + o.width, o.y), (o.x + o.width, o.y + o.depth),
                   (o.x, o.y + o.depth)]
        features.append(_feature("Polygon", [_ring(corners)], kind="obstacle", label=o.label))
    for room in layout.rooms:
        # A room the solve left empty (no area) is an empty Polygon (RFC 7946, 3.1).
        features.append(_feature(
            "Polygon", [_ring(room.polygon)] if room.polygon else [], kind="room", id=room.id,
            type=room.type, area=room.area, size_error=layout.report.size_error.get(room.id),
            region=room.region,
        ))
    for aisle in layout.aisles:
        features.append(_feature("Polygon", [_ring(aisle.polygon)] if aisle.polygon else [],
                                 kind="aisle", id=aisle.id,
                                 area=aisle.area, width=aisle.width, regions=aisle.regions))
    for corridor in layout.corridors:
        features.append(_feature("Polygon", [_ring(corridor.polygon)] if corridor.polygon else [],
                                 kind="corridor", id=corridor.id,
                                 area=corridor.area, width=corridor.width))
    for door in layout.doors:
        features.append(_feature("LineString", [list(p) for p in door.segment], kind="door",
                                 between=list(door.between), opens_into=door.opens_into,
                                 front=OUTSIDE in door.between))
    for window in layout.windows:
        features.append(_feature("LineString", [list(p) for p in window.segment],
                                 kind="window", room=window.room))
    return {
        "type": "FeatureCollection",
        "name": problem.name,
        "features": features,
        "properties": {"coverage": layout.report.coverage, "valid": layout.report.valid},
    }


def _feature(geometry: str, coordinates: list[Any], **properties: Any) -> dict[str, Any]:
    return {"type": "Feature", "geometry": {"type": geometry, "coordinates": coordinates},
            "properties": properties}


def _ring(points: Any) -> list[list[float]]:
    """A closed ring; none for no points (a room the solve left empty)."""
    ring = [[float(x), float(y)] for x, y in points]
    return [*ring, ring[0]] if ring else []
