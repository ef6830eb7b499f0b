"""Layouts as GeoJSON (RFC 7946) for GIS and web maps, in the problem's own frame: metres,
x east, y north, origin wherever the user put it. GeoJSON expects longitude/latitude,
so the FeatureCollection says its coordinates are a local metric frame (`"crs"` member,
as RFC 7946 section 4 allows for prior arrangement between parties)."""

from __future__ import annotations

from typing import Any

from floorplan.models import OUTSIDE, Layout, Problem
from floorplan.models.storeys import floor_view
from floorplan.solver.export.floors import floor_layout


def to_geojson(problem: Problem, layout: Layout) -> dict[str, Any]:
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
            for feature in to_geojson(floor_view(problem, floor.id), single)["features"]:
                feature["properties"]["floor"] = floor.id
                features.append(feature)
        collection = to_geojson(problem, Layout(name=layout.name, report=layout.report))
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
        "crs": {"type": "name", "properties": {"name": "local metric frame: metres, x east, "
                                                        "y north"}},
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
