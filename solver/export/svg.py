"""A layout as a standalone SVG drawing: walls with thickness (facade and partitions),
rooms coloured by type with their labels, hatched obstacles, uncovered gaps in red,
doors and windows, the entrance, a scale bar, a north arrow and a title.

The document is built with ``xml.etree`` so every user string (room ids, types,
labels, the problem name) is escaped by the serializer rather than by hand.
"""

from __future__ import annotations

import colorsys
import hashlib
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import Point as ShapelyPoint
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from floorplan.models import Aisle, Layout, Problem, RoomLayout
from floorplan.models.storeys import floor_view
from floorplan.solver.geometry import Box, boundary_edges, rectangles_of

SVG_NS = "http://www.w3.org/2000/svg"

#: Fills for the well-known room types (DESIGN.md §1); anything else gets a hashed pastel.
PALETTE: dict[str, str] = {
    "living": "#f6e2b3",
    "kitchen": "#f9c784",
    "bedroom": "#b9d7f0",
    "bathroom": "#a8e0df",
    "dining": "#f7e3a1",
    "foyer": "#d9cbe8",
    "corridor": "#e4e4e4",
    "study": "#c7e3b5",
    "storage": "#d6ccc2",
    "balcony": "#cfe8c8",
    "office": "#c3cdea",
    "stairs": "#cfcfcf",
    "laundry": "#bfe3f2",
    "shop": "#f3c6dc",
}
WALL_COLOUR = "#222222"
GAP_COLOUR = "#ff9d9d"
#: Aisles between regions: circulation floor, light grey.
AISLE_COLOUR = "#e4e4e4"
ENTRANCE_COLOUR = "#1b7f3b"
TEXT_COLOUR = "#222222"

# Page furniture is in SVG units (pixels), independent of `scale`, so small drawings
# of big buildings keep a readable title and scale bar.
MARGIN = 24.0
TITLE_FONT = 18.0
TITLE_BAND = 36.0
SCALE_BAND = 52.0
MAX_LABEL_FONT = 14.0
MIN_LABEL_FONT = 4.0
#: Typical glyph width / font size for sans-serif text, to estimate label widths.
GLYPH_WIDTH = 0.6

#: Drawn wall thicknesses, metres: a load-bearing facade and a light partition.
EXTERIOR_WALL = 0.25
INTERIOR_WALL = 0.1
#: Door leaves and swings; window panes.
DOOR_COLOUR = "#8a5a2b"
WINDOW_COLOUR = "#3a7bd5"
#: Characters XML 1.0 forbids even when escaped; ids are user input and may carry them.
_XML_INVALID = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ufffe\uffff]")


@dataclass(frozen=True)
class _Frame:
    """Maps model metres (y north) to SVG units (y down) with the page margins."""

    min_x: float
    max_y: float
    scale: float
    left: float
    top: float

    def point(self, x: float, y: float) -> tuple[float, float]:
        return (self.left + (x - self.min_x) * self.scale, self.top + (self.max_y - y) * self.scale)


def render_svg(problem: Problem, layout: Layout, *, scale: float = 40.0) -> str:
    """The layout of `problem` as an SVG document; `scale` is SVG units per metre."""
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive number, not {scale}")
    if layout.floors is not None and problem.floors is not None:
        return _render_storeys(problem, layout, scale)
    outline = problem.outline()
    min_x, min_y, max_x, max_y = outline.bounds
    frame = _Frame(min_x, max_y, scale, MARGIN, MARGIN + TITLE_BAND)
    plan_w, plan_h = (max_x - min_x) * scale, (max_y - min_y) * scale
    width = plan_w + 2 * MARGIN
    height = frame.top + plan_h + SCALE_BAND + MARGIN

    svg = ET.Element("svg", {
        "xmlns": SVG_NS, "version": "1.1",
        "width": _num(width), "height": _num(height),
        "viewBox": f"0 0 {_num(width)} {_num(height)}",
        "font-family": "Helvetica, Arial, sans-serif",
    })
    ET.SubElement(svg, "title").text = _clean(problem.name)
    _add_hatch_pattern(svg)
    ET.SubElement(svg, "rect", {"width": "100%", "height": "100%", "fill": "white"})
    _add_gaps(svg, frame, problem.free_area(), layout.rooms, layout.circulation_spaces)
    for aisle in layout.circulation_spaces:
        _add_aisle(svg, frame, aisle)
    for room in layout.rooms:
        _add_room(svg, frame, room)
    for index, obstacle in enumerate(problem.obstacles):
        _add_obstacle(svg, frame, Box(obstacle.x, obstacle.y, obstacle.x + obstacle.width,
                                      obstacle.y + obstacle.depth), obstacle.label, index)
    _add_interior_walls(svg, frame, layout.rooms, outline)
    _add_outline(svg, frame, outline)
    _add_openings(svg, frame, layout)  # over the walls: they are holes in them
    if problem.entrance is not None:
        _add_entrance(svg, frame, problem)
    _add_title(svg, problem.name)
    _add_scale_bar(svg, frame, max_x - min_x, frame.top + plan_h + SCALE_BAND / 2)
    _add_north_arrow(svg, width - MARGIN - 10, MARGIN, problem.north)
    _indent(svg)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(svg, encoding="unicode")


def _render_storeys(problem: Problem, layout: Layout, scale: float) -> str:
    """A building of several storeys: each floor's plan, titled with its name, side by
    side from the first floor on the left, on one page at one scale."""
    ns = f"{{{SVG_NS}}}"
    plans: list[ET.Element] = []
    for k, floor in enumerate(layout.floors or []):
        single = Layout(name=floor.name, rooms=floor.rooms, doors=floor.doors,
                        windows=floor.windows, report=floor.report)
        plan = ET.fromstring(render_svg(floor_view(problem, floor.id), single, scale=scale))
        # One hatch pattern per floor: ids must stay unique in the whole document.
        for element in plan.iter():
            if element.get("id") == "fp-hatch":
                element.set("id", f"fp-hatch-{k}")
            if element.get("fill") == "url(#fp-hatch)":
                element.set("fill", f"url(#fp-hatch-{k})")
        plan.set("class", "floor")
        plan.set("data-floor", _clean(floor.id))
        plans.append(plan)
    x = 0.0
    for plan in plans:
        plan.set("x", _num(x))
        plan.set("y", "0")
        x += float(plan.get("width", "0"))
    width = max(x, 1.0)
    height = max((float(p.get("height", "0")) for p in plans), default=1.0)
    svg = ET.Element(f"{ns}svg", {
        "version": "1.1", "width": _num(width), "height": _num(height),
        "viewBox": f"0 0 {_num(width)} {_num(height)}",
        "font-family": "Helvetica, Arial, sans-serif",
    })
    ET.SubElement(svg, f"{ns}title").text = _clean(problem.name)
    ET.SubElement(svg, f"{ns}rect", {"width": "100%", "height": "100%", "fill": "white"})
    svg.extend(plans)
    _indent(svg)
    # Parsed plans carry the SVG namespace: written as the default one, not as ns0.
    ET.register_namespace("", SVG_NS)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(svg, encoding="unicode")


def room_fill(room_type: str) -> str:
    """The fill colour for a room type: the palette's, else a pastel derived from a
    stable digest of the name (not `hash()`, which changes between processes)."""
    key = room_type.strip().lower()
    if key in PALETTE:
        return PALETTE[key]
    hue = int.from_bytes(hashlib.sha256(key.encode()).digest()[:2], "big") / 65536
    red, green, blue = colorsys.hls_to_rgb(hue, 0.85, 0.6)
    return "#{:02x}{:02x}{:02x}".format(*(round(c * 255) for c in (red, green, blue)))


def scale_bar_length(width_m: float) -> float:
    """A round length (1, 2 or 5 times a power of ten) close to a fifth of `width_m`.

    >>> [scale_bar_length(w) for w in (10, 12, 30, 100, 3)]
    [2.0, 2.0, 5.0, 20.0, 0.5]
    """
    target = max(width_m, 1e-9) / 5
    exponent = math.floor(math.log10(target))
    candidates = [m * 10.0**e for e in (exponent - 1, exponent, exponent + 1) for m in (1, 2, 5)]
    return min(candidates, key=lambda c: abs(math.log(c / target)))


# Building blocks, in drawing order.


def _add_hatch_pattern(svg: ET.Element) -> None:
    # One diagonal line per tile; rotating the tile keeps the lines continuous.
    defs = ET.SubElement(svg, "defs")
    pattern = ET.SubElement(defs, "pattern", {
        "id": "fp-hatch", "patternUnits": "userSpaceOnUse", "width": "8", "height": "8",
        "patternTransform": "rotate(45)",
    })
    ET.SubElement(pattern, "rect", {"width": "8", "height": "8", "fill": "#eeeeee"})
    ET.SubElement(pattern, "line", {"x1": "0", "y1": "0", "x2": "0", "y2": "8",
                                    "stroke": "#666666", "stroke-width": "2"})


def _add_gaps(svg: ET.Element, frame: _Frame, free: BaseGeometry,
              rooms: Sequence[RoomLayout], aisles: Sequence[Aisle] = ()) -> None:
    # Aisles are floor of the plan, not gaps.
    shapes = [_room_shape(room) for room in rooms] + [
        Polygon(aisle.polygon) for aisle in aisles if len(aisle.polygon) >= 3]
    covered = shapely.union_all([s for s in shapes if s is not None])
    gaps = free.difference(covered)
    parts = [p for p in shapely.get_parts(gaps) if isinstance(p, Polygon) and p.area > 1e-6]
    if parts:
        ET.SubElement(svg, "path", {
            "class": "uncovered", "d": " ".join(_polygon_path(frame, p) for p in parts),
            "fill": GAP_COLOUR, "fill-opacity": "0.6", "fill-rule": "evenodd",
            # A dashed red edge tells a gap from a pinkish room fill.
            "stroke": "#d62728", "stroke-width": "1", "stroke-dasharray": "4 3",
        })


def _add_room(svg: ET.Element, frame: _Frame, room: RoomLayout) -> None:
    shape = _room_shape(room)
    if shape is None:
        return
    group = ET.SubElement(svg, "g", {"class": "room", "data-id": _clean(room.id),
                                     "data-type": _clean(room.type)})
    ET.SubElement(group, "polygon", {
        "points": _points(frame, room.polygon), "fill": room_fill(room.type),
        "stroke": "#555555", "stroke-width": "1",
    })
    _add_label(group, frame, _label_box(shape), [room.id, f"{room.area:.1f} m²"], "room-label")


def _add_aisle(svg: ET.Element, frame: _Frame, aisle: Aisle) -> None:
    """An aisle between regions: light grey floor, labelled where it is wide enough."""
    if len(aisle.polygon) < 3:
        return
    group = ET.SubElement(svg, "g", {"class": "aisle", "data-id": _clean(aisle.id)})
    ET.SubElement(group, "polygon", {"points": _points(frame, aisle.polygon),
                                     "fill": AISLE_COLOUR, "stroke": "none"})
    shape = Polygon(aisle.polygon)
    x0, y0, x1, y1 = shape.bounds
    if max(x1 - x0, y1 - y0) >= 4 * aisle.width:
        _add_label(group, frame, _label_box(shape), [aisle.id], "aisle-label")


def _add_obstacle(svg: ET.Element, frame: _Frame, box: Box, label: str, index: int) -> None:
    group = ET.SubElement(svg, "g", {"class": "obstacle", "data-index": str(index)})
    x, y = frame.point(box.x0, box.y1)
    ET.SubElement(group, "rect", {
        "x": _num(x), "y": _num(y), "width": _num(box.width * frame.scale),
        "height": _num(box.depth * frame.scale), "fill": "url(#fp-hatch)",
        "stroke": WALL_COLOUR, "stroke-width": "1.5",
    })
    _add_label(group, frame, box, [label], "obstacle-label")


def _add_openings(svg: ET.Element, frame: _Frame, layout: Layout) -> None:
    """Doors as an opening with the leaf and its swing into the room it opens into,
    windows as a double line in the wall, as plans draw them."""
    shapes = {room.id: _room_shape(room) for room in layout.rooms}
    for door in layout.doors:
        group = ET.SubElement(svg, "g", {"class": "door"})
        ET.SubElement(group, "title").text = _clean(" / ".join(door.between))
        _add_segment(group, frame, door.segment, "door-gap", "white", _wall_width(frame) + 1)
        into = shapes.get(door.opens_into or "")
        if into is not None:
            _add_swing(group, frame, door.segment, into)
    for window in layout.windows:
        group = ET.SubElement(svg, "g", {"class": "window"})
        _add_segment(group, frame, window.segment, "window-gap", "white", _wall_width(frame) + 1)
        _add_segment(group, frame, window.segment, "window-pane", WINDOW_COLOUR, 2.0)


def _add_swing(parent: ET.Element, frame: _Frame, segment: Sequence[tuple[float, float]],
               room: BaseGeometry) -> None:
    """The leaf, hinged at the segment's start and standing open into `room`, and the
    quarter circle its free end sweeps."""
    (x0, y0), (x1, y1) = segment
    width = math.hypot(x1 - x0, y1 - y0)
    nx, ny = -(y1 - y0) / width, (x1 - x0) / width  # a unit normal to the wall
    probe = ShapelyPoint((x0 + x1) / 2 + nx * 0.05, (y0 + y1) / 2 + ny * 0.05)
    if not room.contains(probe):
        nx, ny = -nx, -ny
    tip = (x0 + nx * width, y0 + ny * width)
    _add_segment(parent, frame, [(x0, y0), tip], "door-leaf", DOOR_COLOUR, 1.5)
    start, end = frame.point(*tip), frame.point(x1, y1)
    radius = width * frame.scale
    # Which way the arc turns on screen follows from the cross product of leaf and wall.
    sweep = 1 if (nx * (y1 - y0) - ny * (x1 - x0)) > 0 else 0
    ET.SubElement(parent, "path", {
        "class": "door-swing", "fill": "none", "stroke": DOOR_COLOUR, "stroke-width": "0.8",
        "stroke-dasharray": "3 2",
        "d": f"M {_num(start[0])},{_num(start[1])} A {_num(radius)},{_num(radius)} 0 0 "
             f"{sweep} {_num(end[0])},{_num(end[1])}",
    })


def _add_north_arrow(svg: ET.Element, x: float, y: float, north: float = 0.0) -> None:
    """An arrow with its tip at (x, y), turned `north` degrees clockwise about its middle
    (`Problem.north`; 0: the problem's y grows north, up the page)."""
    attrs = {"class": "north-arrow"}
    if north:
        attrs["transform"] = f"rotate({_num(north)} {_num(x)} {_num(y + 17)})"
    group = ET.SubElement(svg, "g", attrs)
    ET.SubElement(group, "polygon", {
        "points": f"{_num(x)},{_num(y)} {_num(x - 7)},{_num(y + 20)} {_num(x)},{_num(y + 15)} "
                  f"{_num(x + 7)},{_num(y + 20)}",
        "fill": TEXT_COLOUR,
    })
    label = ET.SubElement(group, "text", {"x": _num(x), "y": _num(y + 34), "font-size": "12",
                                          "text-anchor": "middle", "fill": TEXT_COLOUR})
    label.text = "N"


def _wall_width(frame: _Frame) -> float:
    """Exterior walls drawn EXTERIOR_WALL thick, and never thinner than two units."""
    return max(2.0, EXTERIOR_WALL * frame.scale)


def _add_interior_walls(svg: ET.Element, frame: _Frame, rooms: Sequence[RoomLayout],
                        outline: Polygon) -> None:
    """The partitions: every room edge not on the outline, drawn INTERIOR_WALL thick
    once, however many rooms share it."""
    shapes = [shape for room in rooms if (shape := _room_shape(room)) is not None]
    if not shapes:
        return
    edges = shapely.union_all([shape.boundary for shape in shapes])
    partitions = shapely.line_merge(edges.difference(outline.exterior.buffer(1e-6)))
    lines = [line for line in shapely.get_parts(partitions) if line.length > 1e-6]
    if not lines:
        return
    path = " ".join("M " + " L ".join(_pair(frame, x, y) for x, y in line.coords)
                    for line in lines)
    ET.SubElement(svg, "path", {
        "class": "interior-walls", "d": path, "fill": "none", "stroke": WALL_COLOUR,
        "stroke-width": _num(max(1.0, INTERIOR_WALL * frame.scale)),
        "stroke-linecap": "square", "stroke-linejoin": "miter",
    })


def _add_outline(svg: ET.Element, frame: _Frame, outline: Polygon) -> None:
    ET.SubElement(svg, "path", {
        "class": "outline", "d": _polygon_path(frame, outline), "fill": "none",
        "stroke": WALL_COLOUR, "stroke-width": _num(_wall_width(frame)),
        "stroke-linejoin": "miter",
    })


def _add_entrance(svg: ET.Element, frame: _Frame, problem: Problem) -> None:
    # An arrow outside the wall pointing in through the door, so it reads as "way in".
    assert problem.entrance is not None
    ex, ey = problem.entrance
    edges = boundary_edges(problem.boundary)
    nearest = min(edges, key=lambda e: shapely.LineString([e.start, e.end]).distance(
        ShapelyPoint(ex, ey)))
    out_x, out_y = {"north": (0, 1), "south": (0, -1), "east": (1, 0), "west": (-1, 0)}[
        nearest.facing]
    size = 14.0
    tip = frame.point(ex, ey)
    # SVG y runs down, so the outward normal's y flips.
    back = (tip[0] + out_x * size, tip[1] - out_y * size)
    side = (out_y * size / 2, out_x * size / 2)
    corners = [tip, (back[0] + side[0], back[1] + side[1]), (back[0] - side[0], back[1] - side[1])]
    group = ET.SubElement(svg, "g", {"class": "entrance"})
    ET.SubElement(group, "title").text = "entrance"
    ET.SubElement(group, "polygon", {
        "points": " ".join(f"{_num(x)},{_num(y)}" for x, y in corners),
        "fill": ENTRANCE_COLOUR, "stroke": "white", "stroke-width": "1",
    })
    ET.SubElement(group, "circle", {"cx": _num(tip[0]), "cy": _num(tip[1]), "r": "3",
                                    "fill": ENTRANCE_COLOUR})


def _add_title(svg: ET.Element, name: str) -> None:
    text = ET.SubElement(svg, "text", {
        "class": "title", "x": _num(MARGIN), "y": _num(MARGIN + TITLE_FONT * 0.8),
        "font-size": _num(TITLE_FONT), "font-weight": "bold", "fill": TEXT_COLOUR,
    })
    text.text = _clean(name)


def _add_scale_bar(svg: ET.Element, frame: _Frame, width_m: float, y: float) -> None:
    length = scale_bar_length(width_m)
    x0, x1 = frame.left, frame.left + length * frame.scale
    group = ET.SubElement(svg, "g", {"class": "scale-bar", "stroke": WALL_COLOUR,
                                     "stroke-width": "2"})
    ET.SubElement(group, "line", {"x1": _num(x0), "y1": _num(y), "x2": _num(x1), "y2": _num(y)})
    for x in (x0, x1):
        ET.SubElement(group, "line", {"x1": _num(x), "y1": _num(y - 5),
                                      "x2": _num(x), "y2": _num(y + 5)})
    label = ET.SubElement(svg, "text", {
        "class": "scale-label", "x": _num(x1 + 8), "y": _num(y + 4), "font-size": "12",
        "fill": TEXT_COLOUR,
    })
    label.text = f"{length:g} m"


# Helpers.


def _add_label(parent: ET.Element, frame: _Frame, box: Box, lines: Sequence[str],
               css_class: str) -> None:
    """Centred lines of text in `box`, with a font small enough to fit (within limits)."""
    lines = [_clean(line) for line in lines]
    box_w, box_h = box.width * frame.scale, box.depth * frame.scale
    longest = max((len(line) for line in lines), default=1) or 1
    font = min(MAX_LABEL_FONT, 0.9 * box_w / (GLYPH_WIDTH * longest),
               0.8 * box_h / (1.2 * len(lines)))
    font = max(MIN_LABEL_FONT, font)
    cx, cy = frame.point((box.x0 + box.x1) / 2, (box.y0 + box.y1) / 2)
    # Centre the block of lines vertically; each baseline sits ~0.35 em below its middle.
    first = cy - (len(lines) - 1) * 0.6 * font + 0.35 * font
    text = ET.SubElement(parent, "text", {
        "class": css_class, "x": _num(cx), "y": _num(first), "font-size": _num(font),
        "text-anchor": "middle", "fill": TEXT_COLOUR,
    })
    for index, line in enumerate(lines):
        span = ET.SubElement(text, "tspan", {"x": _num(cx)})
        if index:
            span.set("dy", "1.2em")
        span.text = line


def _indent(svg: ET.Element) -> None:
    """Indent for readable output, except inside <text>: whitespace there is rendered,
    and it would shift centred labels."""
    ET.indent(svg)
    for text in svg.iter("text"):
        if len(text):
            text.text = None
            for span in text:
                span.tail = None


def _label_box(shape: BaseGeometry) -> Box:
    # The largest rectangle of the room's decomposition keeps an L-shaped room's label
    # inside the room, where the bounding-box centre might fall outside it.
    boxes = rectangles_of(shape)
    if boxes:
        return max(boxes, key=lambda b: b.area)
    return Box(*shape.bounds)


def _room_shape(room: RoomLayout) -> BaseGeometry | None:
    if len(room.polygon) < 3:
        return None
    # A hand-made or buggy polygon may cross itself; keep its areal parts rather than fail.
    repaired = shapely.make_valid(Polygon(room.polygon))
    shape = shapely.union_all([p for p in shapely.get_parts(repaired) if isinstance(p, Polygon)])
    return shape if shape.area > 0 else None


def _add_segment(svg: ET.Element, frame: _Frame, segment: Sequence[tuple[float, float]],
                 css_class: str, colour: str, width: float) -> None:
    (x1, y1), (x2, y2) = (frame.point(*p) for p in segment)
    ET.SubElement(svg, "line", {
        "class": css_class, "x1": _num(x1), "y1": _num(y1), "x2": _num(x2), "y2": _num(y2),
        "stroke": colour, "stroke-width": _num(width), "stroke-linecap": "butt",
    })


def _polygon_path(frame: _Frame, polygon: Polygon) -> str:
    rings = [polygon.exterior, *polygon.interiors]
    return " ".join(_ring_path(frame, list(ring.coords)[:-1]) for ring in rings)


def _ring_path(frame: _Frame, coords: Iterable[Sequence[float]]) -> str:
    return "M " + " L ".join(_pair(frame, x, y) for x, y in coords) + " Z"


def _points(frame: _Frame, coords: Iterable[Sequence[float]]) -> str:
    return " ".join(_pair(frame, x, y) for x, y in coords)


def _pair(frame: _Frame, x: float, y: float) -> str:
    sx, sy = frame.point(x, y)
    return f"{_num(sx)},{_num(sy)}"


def _num(value: float) -> str:
    """Compact coordinates: two decimals are far below a pixel, and no '-0'."""
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _clean(text: str) -> str:
    return _XML_INVALID.sub("\ufffd", text)
