"""Layouts as DXF drawings for CAD, in metres, in the problem's own frame: a layer per room
type, the outline, obstacles, doors, windows and aisles."""

from __future__ import annotations

import io
from typing import Any

import ezdxf
from ezdxf import colors
from ezdxf.enums import TextEntityAlignment

from models import Layout, Problem
from models.storeys import floor_view
from solver.export.floors import floor_layout

#: DXF colour index per room type; other types get a colour from their name.
TYPE_COLOURS = {"living": 2, "kitchen": 30, "bedroom": 5, "bathroom": 4, "dining": 40,
                "foyer": 6, "corridor": 8, "hall": 8, "study": 3, "storage": 9,
                "balcony": 94, "office": 150, "stairs": 250}


def to_dxf(problem: Problem, layout: Layout) -> bytes:
    """A DXF drawing in metres: a layer per room type with each room as a closed
    polyline and its label, layers OUTLINE, OBSTACLES, DOORS, WINDOWS and (with
    regions) AISLES. In a building of several storeys every floor is drawn in place, in
    layers of its own named after it (``GROUND-OUTLINE``, ``GROUND-ROOM_BEDROOM``), so a
    CAD user shows one at a time."""
    doc = ezdxf.new("R2010", setup=True)
    doc.units = ezdxf.units.M
    if layout.floors is not None and problem.floors is not None:
        for floor in layout.floors:
            _draw_dxf(doc, floor_view(problem, floor.id), floor_layout(layout, floor.id),
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


def _layer_name(room_type: str) -> str:
    """DXF layer names may not hold <>/\\":;?*|=' and stay short."""
    clean = "".join(c if c.isalnum() or c in "-_" else "_" for c in room_type.upper())
    return f"ROOM_{clean[:40] or 'ROOM'}"


def _colour_of(name: str) -> int:
    return 10 + sum(map(ord, name)) % 240


def _label_point(rectangles: Any) -> tuple[float, float]:
    largest = max(rectangles, key=lambda r: r.width * r.depth)
    return largest.x + largest.width / 2, largest.y + largest.depth / 2
