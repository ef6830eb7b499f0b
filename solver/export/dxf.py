"""Layouts as DXF drawings for CAD, in metres, in the problem's own frame.

By default (``layers="ncs"``) the layers are those of the AIA / US National CAD Standard
(NCS 6, discipline A, architecture), as an architect's own drawings name them:

========== ===================================================================
A-WALL     walls: each as a closed polyline of its thickness (facade 25 cm,
           partitions 10 cm, as `solver.export.walls` finds them), cut at the
           doors and windows
A-WALL-PATT the walls' solid fill (a hatch), to turn off for a lighter plan
A-DOOR     doors: the leaf standing open into its room and its swing arc
A-GLAZ     windows: the opening's outline in the wall and the glass line
A-AREA     every room's and aisle's outline, a closed polyline
A-AREA-IDEN the room's id and area, at its middle
A-FLOR-OTLN the outline of the floor
A-COLS     obstacles labelled as columns; A-FLOR-OBST the other obstacles
A-FLOR-LEVL in a building of several storeys: one layer per storey
           (``A-FLOR-LEVL-GROUND``), holding the storey's level mark
========== ===================================================================

In a building of several storeys each storey is a block (``STOREY-GROUND``) inserted at
its elevation on its ``A-FLOR-LEVL-...`` layer: the plans lie one above the other, and
freezing a storey's layer hides that storey, the usual way to show one floor at a time.

``layers="room-type"`` draws the older drawing instead: a layer per room type
(``ROOM_BEDROOM``) with each room's outline and label, and layers OUTLINE, OBSTACLES,
DOORS, WINDOWS and AISLES; storeys in layers of their own (``GROUND-ROOM_BEDROOM``).
"""

from __future__ import annotations

import io
import math
from typing import Any

import ezdxf
import shapely
from ezdxf import colors
from ezdxf.enums import MTextEntityAlignment, TextEntityAlignment
from ezdxf.layouts import BaseLayout
from shapely.geometry import Point, Polygon, box

from floorplan.models import Layout, Problem
from floorplan.models.formats import DEFAULT_STOREY_HEIGHT, DxfLayers
from floorplan.models.storeys import floor_view
from floorplan.solver.export.floors import floor_layout
from floorplan.solver.export.walls import WallSegment, wall_segments, walls_of

#: DXF colour index per room type; other types get a colour from their name.
TYPE_COLOURS = {"living": 2, "kitchen": 30, "bedroom": 5, "bathroom": 4, "dining": 40,
                "foyer": 6, "corridor": 8, "hall": 8, "study": 3, "storage": 9,
                "balcony": 94, "office": 150, "stairs": 250}

#: The NCS layers: name -> (colour, lineweight in 1/100 mm, description).
NCS_LAYERS: dict[str, tuple[int, int, str]] = {
    "A-WALL": (colors.WHITE, 50, "Walls"),
    "A-WALL-PATT": (colors.GRAY, 13, "Walls: fill"),
    "A-DOOR": (colors.YELLOW, 25, "Doors: leaves and swings"),
    "A-GLAZ": (colors.CYAN, 25, "Windows: openings and glazing"),
    "A-AREA": (colors.GREEN, 18, "Room and circulation outlines"),
    "A-AREA-IDEN": (colors.WHITE, 18, "Room names and areas"),
    "A-FLOR-OTLN": (colors.WHITE, 35, "Floor outline"),
    "A-COLS": (colors.MAGENTA, 35, "Columns"),
    "A-FLOR-OBST": (colors.MAGENTA, 25, "Obstacles: cores, shafts, voids"),
}
#: The prefix of a storey's layer in a building of several.
LEVEL_LAYER = "A-FLOR-LEVL"
#: Text heights, metres.
ROOM_TEXT = 0.25
LEVEL_TEXT = 0.4
#: An obstacle whose label holds one of these is drawn as a column.
COLUMN_WORDS = ("column", "pillar", "pier")


def to_dxf(problem: Problem, layout: Layout, *, layers: DxfLayers = "ncs",
           storey_height: float = DEFAULT_STOREY_HEIGHT) -> bytes:
    """The layout as a DXF drawing (R2010, metres) with the layers `layers` names (see
    the module docstring); storeys `storey_height` apart."""
    doc = ezdxf.new("R2010", setup=True, units=ezdxf.units.M)
    if layers == "room-type":
        _draw_by_type(doc, problem, layout)
    else:
        _draw_ncs(doc, problem, layout, storey_height)
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue().encode("utf-8")


# --- AIA / NCS layers ---------------------------------------------------------------


def _draw_ncs(doc: Any, problem: Problem, layout: Layout, storey_height: float) -> None:
    for name, (colour, weight, description) in NCS_LAYERS.items():
        doc.layers.add(name, color=colour, lineweight=weight).description = description
    if layout.floors is None or problem.floors is None:
        _draw_floor(doc.modelspace(), problem, layout)
        return
    for k, floor in enumerate(layout.floors):
        tag = _clean(floor.id)
        layer = f"{LEVEL_LAYER}-{tag}"
        if layer not in doc.layers:  # two floor ids may clean to one name
            doc.layers.add(layer, color=colors.WHITE).description = _plain(
                f"Storey {floor.name}")
        name = f"STOREY-{tag}"
        while name in doc.blocks:
            name += "_"
        block = doc.blocks.new(name=name)
        view = floor_view(problem, floor.id)
        _draw_floor(block, view, floor_layout(layout, floor.id))
        elevation = k * storey_height
        x, y = view.outline().bounds[:2]
        block.add_text(_plain(f"{floor.name}  {elevation:+.2f}"), height=LEVEL_TEXT,
                       dxfattribs={"layer": layer}).set_placement(
            (x, y - 2 * LEVEL_TEXT), align=TextEntityAlignment.BOTTOM_LEFT)
        doc.modelspace().add_blockref(name, (0.0, 0.0, elevation), dxfattribs={"layer": layer})


def _draw_floor(space: BaseLayout, problem: Problem, layout: Layout) -> None:
    """One floor in `space` (the modelspace, or a storey's block), on the NCS layers."""
    space.add_lwpolyline(problem.boundary, close=True, dxfattribs={"layer": "A-FLOR-OTLN"})
    for o in problem.obstacles:
        column = any(word in o.label.lower() for word in COLUMN_WORDS)
        space.add_lwpolyline(_ring(o.to_box()), close=True,
                             dxfattribs={"layer": "A-COLS" if column else "A-FLOR-OBST"})
    # A room the solve left without floor (an empty polygon) has nothing to draw.
    shapes = {room.id: Polygon(room.polygon) for room in layout.rooms if room.polygon}
    shapes |= {aisle.id: Polygon(aisle.polygon) for aisle in layout.circulation_spaces}
    for room in layout.rooms:
        if room.id not in shapes:
            continue
        space.add_lwpolyline(room.polygon, close=True, dxfattribs={"layer": "A-AREA"})
        label = space.add_mtext(f"{_mtext(room.id)}\\P{room.area:.2f} m²", dxfattribs={
            "layer": "A-AREA-IDEN", "char_height": ROOM_TEXT})
        label.set_location(_label_point(shapes[room.id]),
                           attachment_point=MTextEntityAlignment.MIDDLE_CENTER)
    for aisle in layout.circulation_spaces:
        space.add_lwpolyline(aisle.polygon, close=True, dxfattribs={"layer": "A-AREA"})
    walls = wall_segments(shapes, problem.outline(),
                          circulation={a.id for a in layout.circulation_spaces},
                          obstacles=[o.to_box() for o in problem.obstacles])
    cuts: dict[int, list[Polygon]] = {}
    for door, wall in zip(layout.doors, walls_of(walls, [d.segment for d in layout.doors]),
                          strict=True):
        if wall is not None:
            cuts.setdefault(id(wall), []).append(_opening(wall, door.segment))
        into = shapes.get(door.opens_into or "")
        if into is not None:
            _draw_swing(space, door.segment, into)
    for window, wall in zip(layout.windows,
                            walls_of(walls, [w.segment for w in layout.windows]), strict=True):
        if wall is None:
            continue
        opening = _opening(wall, window.segment)
        cuts.setdefault(id(wall), []).append(opening)
        space.add_lwpolyline(_ring(opening), close=True, dxfattribs={"layer": "A-GLAZ"})
        (x0, y0), (x1, y1) = window.segment
        nx, ny = _left_normal(wall)
        mid = wall.offset + wall.thickness / 2  # the glass in the middle of the wall
        space.add_line((x0 + nx * mid, y0 + ny * mid), (x1 + nx * mid, y1 + ny * mid),
                       dxfattribs={"layer": "A-GLAZ"})
    for wall in walls:
        body = wall.footprint()
        if id(wall) in cuts:
            body = body.difference(shapely.union_all(cuts[id(wall)]))
        for part in shapely.get_parts(body):
            if part.area <= 0:
                continue
            space.add_lwpolyline(_ring(part), close=True, dxfattribs={"layer": "A-WALL"})
            hatch = space.add_hatch(color=colors.GRAY, dxfattribs={"layer": "A-WALL-PATT"})
            hatch.paths.add_polyline_path(_ring(part), is_closed=True)


def _opening(wall: WallSegment, segment: tuple[tuple[float, float], tuple[float, float]],
             ) -> Polygon:
    """The part of `wall`'s body a door or window along `segment` takes."""
    (x0, y0), (x1, y1) = segment
    nx, ny = _left_normal(wall)
    lo, hi = wall.offset, wall.offset + wall.thickness
    return Polygon([(x0 + nx * lo, y0 + ny * lo), (x1 + nx * lo, y1 + ny * lo),
                    (x1 + nx * hi, y1 + ny * hi), (x0 + nx * hi, y0 + ny * hi)]).normalize()


def _draw_swing(space: BaseLayout, segment: tuple[tuple[float, float], tuple[float, float]],
                room: Polygon) -> None:
    """The leaf, hinged at the segment's start and standing open into `room`, and the
    quarter circle its free end sweeps to the segment's end (as the SVG plan draws
    it)."""
    (x0, y0), (x1, y1) = segment
    width = math.hypot(x1 - x0, y1 - y0)
    nx, ny = -(y1 - y0) / width, (x1 - x0) / width
    if not room.contains(Point((x0 + x1) / 2 + nx * 0.05, (y0 + y1) / 2 + ny * 0.05)):
        nx, ny = -nx, -ny
    space.add_line((x0, y0), (x0 + nx * width, y0 + ny * width), dxfattribs={"layer": "A-DOOR"})
    closed = math.degrees(math.atan2(y1 - y0, x1 - x0))
    opened = math.degrees(math.atan2(ny, nx))
    # Arcs run counter-clockwise: from the wall to the leaf when the leaf is to the left.
    left = (x1 - x0) * ny - (y1 - y0) * nx > 0
    start, end = (closed, opened) if left else (opened, closed)
    space.add_arc((x0, y0), width, start, end, dxfattribs={"layer": "A-DOOR"})


def _left_normal(wall: WallSegment) -> tuple[float, float]:
    dx, dy = wall.direction
    return -dy, dx


def _ring(shape: Polygon) -> list[tuple[float, float]]:
    return [(x, y) for x, y in list(shape.exterior.coords)[:-1]]


def _label_point(shape: Polygon) -> tuple[float, float]:
    """Where a room's label goes: its centroid, or when that falls outside (an L),
    the point inside farthest from its walls."""
    centre = shape.centroid
    if shape.contains(centre):
        return centre.x, centre.y
    inner = shapely.maximum_inscribed_circle(shape).coords[0]
    return inner[0], inner[1]


def _mtext(text: str) -> str:
    r"""User text as MTEXT content: its backslashes and braces escaped, so an id never
    reads as formatting, and control characters as spaces.

    >>> print(_mtext(r"a\Pb {x}"))
    a\\Pb \{x\}
    """
    text = _plain(text)
    return text.replace("\\", "\\\\").replace("{", "\\{").replace("}", "\\}")


def _plain(text: str) -> str:
    """User text as a DXF value: every control character (C0, DEL, C1) a space. A DXF
    file is lines of group code and value, so a newline in a value (a floor name in a
    layer's description, an id in a TEXT) would start lines of the writer's choosing:
    group codes, entities, layers of its own.

    >>> _plain("a\\n8\\nPWNED\\r\\x00b")
    'a 8 PWNED  b'
    """
    return "".join(" " if ord(c) < 32 or 127 <= ord(c) < 160 else c for c in text)


def _clean(name: str) -> str:
    """A name as part of a DXF layer or block name: upper case, no <>/\\":;?*|=' ,
    short."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name.upper())[:40] or "ROOM"


# --- A layer per room type (the older drawing) --------------------------------------


def _draw_by_type(doc: Any, problem: Problem, layout: Layout) -> None:
    if layout.floors is not None and problem.floors is not None:
        for floor in layout.floors:
            _draw_types(doc, floor_view(problem, floor.id), floor_layout(layout, floor.id),
                        prefix=f"{_clean(floor.id)}-")
    else:
        _draw_types(doc, problem, layout)


def _draw_types(doc: Any, problem: Problem, layout: Layout, prefix: str = "") -> None:
    """One floor's outline, obstacles, rooms, doors and windows, in layers named with
    `prefix`."""
    msp = doc.modelspace()
    for name, colour in (("OUTLINE", colors.BLACK), ("OBSTACLES", colors.GRAY),
                         ("DOORS", colors.RED), ("WINDOWS", colors.BLUE),
                         *((("AISLES", colors.GRAY),) if layout.circulation_spaces else ())):
        if prefix + name not in doc.layers:  # two floor ids may clean to one name
            doc.layers.add(prefix + name, color=colour, **(
                {"lineweight": 50} if name == "OUTLINE" else {}))
    msp.add_lwpolyline(problem.boundary, close=True, dxfattribs={"layer": prefix + "OUTLINE"})
    for o in problem.obstacles:
        msp.add_lwpolyline(_ring(box(o.x, o.y, o.x + o.width, o.y + o.depth)), close=True,
                           dxfattribs={"layer": prefix + "OBSTACLES"})
    for room in layout.rooms:
        layer = prefix + f"ROOM_{_clean(room.type)}"
        if layer not in doc.layers:
            doc.layers.add(layer, color=TYPE_COLOURS.get(room.type, _colour_of(room.type)))
        msp.add_lwpolyline(room.polygon, close=True, dxfattribs={"layer": layer})
        largest = max(room.rectangles, key=lambda r: r.width * r.depth)
        label = msp.add_text(_plain(f"{room.id} {room.area:.1f} m2"), height=0.25,
                             dxfattribs={"layer": layer})
        label.set_placement((largest.x + largest.width / 2, largest.y + largest.depth / 2),
                            align=TextEntityAlignment.MIDDLE_CENTER)
    for aisle in layout.circulation_spaces:
        msp.add_lwpolyline(aisle.polygon, close=True, dxfattribs={"layer": prefix + "AISLES"})
    for door in layout.doors:
        msp.add_line(*door.segment, dxfattribs={"layer": prefix + "DOORS"})
    for window in layout.windows:
        msp.add_line(*window.segment, dxfattribs={"layer": prefix + "WINDOWS"})


def _colour_of(name: str) -> int:
    return 10 + sum(map(ord, name)) % 240
