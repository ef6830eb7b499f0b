"""Layouts for other tools: GeoJSON for GIS and web maps, DXF for CAD.

Both use the problem's own frame: metres, x east, y north, origin wherever the user
put it. GeoJSON (RFC 7946) expects longitude/latitude, so the FeatureCollection says
its coordinates are a local metric frame (`"crs"` member, as RFC 7946 §4 allows for
prior arrangement between parties).
"""

from __future__ import annotations

import io
import json
from typing import Any, Literal

import ezdxf
from ezdxf import colors
from ezdxf.enums import TextEntityAlignment

from models import OUTSIDE, Layout, Problem

Format = Literal["json", "svg", "dxf", "geojson"]
#: Media types of the formats a layout can be written in.
MEDIA_TYPES: dict[str, str] = {
    "json": "application/json",
    "svg": "image/svg+xml",
    "dxf": "image/vnd.dxf",
    "geojson": "application/geo+json",
}
#: DXF colour index per room type; other types get a colour from their name.
TYPE_COLOURS = {"living": 2, "kitchen": 30, "bedroom": 5, "bathroom": 4, "dining": 40,
                "foyer": 6, "corridor": 8, "hall": 8, "study": 3, "storage": 9,
                "balcony": 94, "office": 150, "stairs": 250}


def to_geojson(problem: Problem, layout: Layout) -> dict[str, Any]:
    """One Feature per room (Polygon, counter-clockwise) with its id, type, area and
    size error (and region); aisles as Polygon features of kind "aisle"; doors and
    windows as LineString features; the outline and obstacles as features of their own.
    In a building of several storeys, every feature of a floor has that floor's id as
    its `floor` property."""
    if layout.floors is not None and problem.floors is not None:
        from models.storeys import floor_view

        features: list[dict[str, Any]] = []
        for floor in layout.floors:
            single = _floor_layout(layout, floor.id)
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
        features.append(_feature(
            "Polygon", [_ring(room.polygon)], kind="room", id=room.id, type=room.type,
            area=room.area, size_error=layout.report.size_error.get(room.id),
            region=room.region,
        ))
    for aisle in layout.aisles:
        features.append(_feature("Polygon", [_ring(aisle.polygon)], kind="aisle", id=aisle.id,
                                 area=aisle.area, width=aisle.width, regions=aisle.regions))
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


def to_dxf(problem: Problem, layout: Layout) -> bytes:
    """A DXF drawing in metres: a layer per room type with each room as a closed
    polyline and its label, layers OUTLINE, OBSTACLES, DOORS, WINDOWS and (with
    regions) AISLES. In a building of several storeys every floor is drawn in place, in
    layers of its own named after it (``GROUND-OUTLINE``, ``GROUND-ROOM_BEDROOM``), so a
    CAD user shows one at a time."""
    doc = ezdxf.new("R2010", setup=True)
    doc.units = ezdxf.units.M
    if layout.floors is not None and problem.floors is not None:
        from models.storeys import floor_view

        for floor in layout.floors:
            _draw_dxf(doc, floor_view(problem, floor.id), _floor_layout(layout, floor.id),
                      prefix=f"{_layer_name(floor.id).removeprefix('ROOM_')}-")
    else:
        _draw_dxf(doc, problem, layout)
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue().encode("utf-8")


def _draw_dxf(doc: Any, problem: Problem, layout: Layout, prefix: str = "") -> None:
    """One floor's outline, obstacles, rooms, doors and windows, in layers named with
    `prefix`."""
    msp = doc.modelspace()
    for name, colour in (("OUTLINE", colors.BLACK), ("OBSTACLES", colors.GRAY),
                         ("DOORS", colors.RED), ("WINDOWS", colors.BLUE),
                         *((("AISLES", colors.GRAY),) if layout.aisles else ())):
        if prefix + name not in doc.layers:  # two floor ids may clean to one name
            doc.layers.add(prefix + name, color=colour, **(
                {"lineweight": 50} if name == "OUTLINE" else {}))
    msp.add_lwpolyline(problem.boundary, close=True, dxfattribs={"layer": prefix + "OUTLINE"})
    for o in problem.obstacles:
        msp.add_lwpolyline([(o.x, o.y), (o.x + o.width, o.y), (o.x + o.width, o.y + o.depth),
                            (o.x, o.y + o.depth)], close=True,
                           dxfattribs={"layer": prefix + "OBSTACLES"})
    for room in layout.rooms:
        layer = prefix + _layer_name(room.type)
        if layer not in doc.layers:
            doc.layers.add(layer, color=TYPE_COLOURS.get(room.type, _colour_of(room.type)))
        msp.add_lwpolyline(room.polygon, close=True, dxfattribs={"layer": layer})
        x, y = _label_point(room.rectangles)
        label = msp.add_text(f"{room.id} {room.area:.1f} m2", height=0.25,
                             dxfattribs={"layer": layer})
        label.set_placement((x, y), align=TextEntityAlignment.MIDDLE_CENTER)
    for aisle in layout.aisles:
        msp.add_lwpolyline(aisle.polygon, close=True, dxfattribs={"layer": prefix + "AISLES"})
    for door in layout.doors:
        msp.add_line(*door.segment, dxfattribs={"layer": prefix + "DOORS"})
    for window in layout.windows:
        msp.add_line(*window.segment, dxfattribs={"layer": prefix + "WINDOWS"})


def _floor_layout(layout: Layout, floor_id: str) -> Layout:
    """Floor `floor_id` of a building's layout as a single-floor layout."""
    floor = next(f for f in layout.floors or [] if f.id == floor_id)
    return Layout(name=floor.name, rooms=floor.rooms, doors=floor.doors,
                  windows=floor.windows, report=floor.report)


def render(problem: Problem, layout: Layout, fmt: Format) -> bytes:
    """`layout` in `fmt`, as the bytes of a file."""
    if fmt == "json":
        return layout.model_dump_json(indent=2).encode()
    if fmt == "geojson":
        return json.dumps(to_geojson(problem, layout), indent=1).encode()
    if fmt == "dxf":
        return to_dxf(problem, layout)
    from solver.export.svg import render_svg

    return render_svg(problem, layout).encode()


def _feature(geometry: str, coordinates: list[Any], **properties: Any) -> dict[str, Any]:
    return {"type": "Feature", "geometry": {"type": geometry, "coordinates": coordinates},
            "properties": properties}


def _ring(points: Any) -> list[list[float]]:
    ring = [[float(x), float(y)] for x, y in points]
    return [*ring, ring[0]]


def _layer_name(room_type: str) -> str:
    """DXF layer names may not hold <>/\\":;?*|=' and stay short."""
    clean = "".join(c if c.isalnum() or c in "-_" else "_" for c in room_type.upper())
    return f"ROOM_{clean[:40] or 'ROOM'}"


def _colour_of(name: str) -> int:
    return 10 + sum(map(ord, name)) % 240


def _label_point(rectangles: Any) -> tuple[float, float]:
    largest = max(rectangles, key=lambda r: r.width * r.depth)
    return largest.x + largest.width / 2, largest.y + largest.depth / 2
