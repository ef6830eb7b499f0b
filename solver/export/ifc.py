"""Layouts as IFC4 building models for BIM tools (Revit, ArchiCAD, Bonsai, any IFC
viewer), written with ifcopenshell's API, in metres in the problem's own frame.

The hierarchy: IfcProject -> IfcSite -> IfcBuilding -> one IfcBuildingStorey per floor
(the first at elevation 0, each next one storey height higher). On each storey:

- an IfcSpace per room, its footprint extruded to the storey height; `Name` the room
  id, `LongName` and `ObjectType` its type, and `Qto_SpaceBaseQuantities` (NetFloorArea,
  GrossPerimeter, Height) from the layout. Aisles are spaces of type ``circulation``.
  A vertical room (stairs, a lift) is one space spanning its storeys: it belongs to the
  lowest and is referenced from the others.
- an IfcWall per wall of `solver.export.walls` (facade 25 cm, partitions 10 cm, each
  built once), with `Pset_WallCommon.IsExternal`, and an IfcRelSpaceBoundary from each
  space it bounds, with the face they share as its connection geometry.
- an IfcDoor (2.1 m high) and an IfcWindow (from a 0.9 m sill, 1.2 m high) at each of
  the layout's doors and windows, at their position and width, each filling an
  IfcOpeningElement that voids its wall.
- obstacles as IfcColumn when their label says column or pillar, else as
  IfcBuildingElementProxy named by their label, the storey's height.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import ifcopenshell
import ifcopenshell.api.aggregate
import ifcopenshell.api.boundary
import ifcopenshell.api.context
import ifcopenshell.api.feature
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.guid
from ifcopenshell.util.shape_builder import ShapeBuilder
from shapely.geometry import Polygon

from floorplan.models import Layout, Problem
from floorplan.models.formats import DEFAULT_STOREY_HEIGHT, ExportOptions
from floorplan.models.storeys import floor_view, spanned_floors
from floorplan.solver.export.floors import floor_layout
from floorplan.solver.export.walls import WallSegment, wall_segments, walls_of

#: Door leaves' height, metres (a standard door set).
DOOR_HEIGHT = 2.1
#: Windows: the sill above the floor and the height of the window, metres; the head
#: lines up with the doors'.
SILL_HEIGHT = 0.9
WINDOW_HEIGHT = 1.2
#: An opening runs this much beyond each face of its wall, metres, so that it cuts
#: clean through.
OPENING_MARGIN = 0.01
Segment = tuple[tuple[float, float], tuple[float, float]]

#: The space type of aisles.
CIRCULATION = "circulation"
#: Obstacles whose label matches this are columns; the rest are generic elements.
COLUMN_LABEL = re.compile(r"column|pillar|pier", re.IGNORECASE)


def to_ifc(problem: Problem, layout: Layout, *,
           storey_height: float = DEFAULT_STOREY_HEIGHT) -> bytes:
    """The layout as an IFC4 file (STEP text): storeys `storey_height` metres apart,
    spaces, walls, doors, windows and obstacles, as the module docstring says."""
    ExportOptions(storey_height=storey_height)  # refuses a height out of range
    model = _Model.start(problem.name, storey_height, problem.north)
    if layout.floors is not None and problem.floors is not None:
        verticals = {v.id: spanned_floors(problem, v) for v in problem.vertical}
        order = [f.id for f in problem.floors]
        for k, floor in enumerate(layout.floors):
            storey = model.storey(floor.name, k * storey_height)
            model.floor(storey, floor_view(problem, floor.id), floor_layout(layout, floor.id),
                        spans={room: order.index(ids[-1]) - order.index(ids[0]) + 1
                               for room, ids in verticals.items() if floor.id in ids})
    else:
        model.floor(model.storey(problem.name, 0.0), problem, layout, spans={})
    return model.file.to_string().encode()


@dataclass
class _Model:
    """An IFC file being written: its project, contexts and building."""

    file: ifcopenshell.file
    body: Any
    building: Any
    height: float
    builder: ShapeBuilder
    #: Vertical rooms already placed, by id: one space for every storey they span.
    shared_spaces: dict[str, Any] = field(default_factory=dict)
    #: IfcDirection instances by their ratios, shared by every placement.
    directions: dict[tuple[float, ...], Any] = field(default_factory=dict)
    #: Door and window types by class, width, height and wall thickness: one per size,
    #: its shape mapped into every door or window of that size.
    types: dict[tuple[str, float, float, float], Any] = field(default_factory=dict)

    @classmethod
    def start(cls, name: str, height: float, north: float = 0.0) -> _Model:
        f = ifcopenshell.api.project.create_file(version="IFC4")
        project = ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name=name)
        ifcopenshell.api.unit.assign_unit(f, length={"is_metric": True, "raw": "METERS"})
        model = ifcopenshell.api.context.add_context(f, context_type="Model")
        # True north in the plan's frame (`Problem.north`, clockwise from +y), as IFC4
        # wants it: a 2D direction in the model context's xy-plane.
        turn = math.radians(north)
        model.TrueNorth = f.createIfcDirection((_ratio(math.sin(turn)), _ratio(math.cos(turn))))
        body = ifcopenshell.api.context.add_context(
            f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW",
            parent=model)
        site = ifcopenshell.api.root.create_entity(f, ifc_class="IfcSite", name="site")
        building = ifcopenshell.api.root.create_entity(f, ifc_class="IfcBuilding", name=name)
        ifcopenshell.api.aggregate.assign_object(f, products=[site], relating_object=project)
        ifcopenshell.api.aggregate.assign_object(f, products=[building], relating_object=site)
        self = cls(f, body, building, height, ShapeBuilder(f))
        site.ObjectPlacement = self.placement(None, (0.0, 0.0, 0.0))
        building.ObjectPlacement = self.placement(site.ObjectPlacement, (0.0, 0.0, 0.0))
        return self

    def storey(self, name: str, elevation: float) -> Any:
        storey = ifcopenshell.api.root.create_entity(
            self.file, ifc_class="IfcBuildingStorey", name=name)
        storey.Elevation = elevation
        ifcopenshell.api.aggregate.assign_object(
            self.file, products=[storey], relating_object=self.building)
        storey.ObjectPlacement = self.placement(self.building.ObjectPlacement,
                                                (0.0, 0.0, elevation))
        return storey

    def floor(self, storey: Any, problem: Problem, layout: Layout,
              spans: dict[str, int]) -> None:
        """One floor's spaces, walls, openings and obstacles on `storey`; the rooms in
        `spans` are vertical, spanning that many storeys from the first that has them.

        The elements are made, then put in their storey all at once, then shaped and
        placed: the API re-places an element it relates that already has a placement,
        at a few milliseconds each, and one by one its calls would take most of the
        time."""
        spaces: dict[str, Any] = {}
        shapes: dict[str, Polygon] = {}
        new: list[tuple[Any, Polygon, float, float]] = []
        referenced: list[Any] = []
        for room in layout.rooms:
            shapes[room.id] = Polygon(room.polygon)
            if room.id in spans and room.id in self.shared_spaces:
                spaces[room.id] = self.shared_spaces[room.id]
                referenced.append(spaces[room.id])
                continue
            spaces[room.id] = self.rooted("IfcSpace", room.id, "INTERNAL",
                                          LongName=room.type, ObjectType=room.type)
            new.append((spaces[room.id], shapes[room.id], room.area,
                        self.height * spans.get(room.id, 1)))
            if room.id in spans:
                self.shared_spaces[room.id] = spaces[room.id]
        for aisle in layout.circulation_spaces:
            shapes[aisle.id] = Polygon(aisle.polygon)
            spaces[aisle.id] = self.rooted("IfcSpace", aisle.id, "INTERNAL",
                                           LongName=CIRCULATION, ObjectType=CIRCULATION)
            new.append((spaces[aisle.id], shapes[aisle.id], aisle.area, self.height))
        ifcopenshell.api.aggregate.assign_object(
            self.file, products=[space for space, *_ in new], relating_object=storey)
        if referenced:
            ifcopenshell.api.spatial.reference_structure(
                self.file, products=referenced, relating_structure=storey)
        for space, shape, area, height in new:
            if not shape.is_empty:  # a room the solve left without floor has no body
                self.extruded(space, storey, shape, height)
            qto = ifcopenshell.api.pset.add_qto(
                self.file, product=space, name="Qto_SpaceBaseQuantities")
            ifcopenshell.api.pset.edit_qto(self.file, qto=qto, properties={
                "NetFloorArea": area, "GrossPerimeter": shape.exterior.length,
                "Height": height})

        walls = wall_segments({k: p for k, p in shapes.items() if not p.is_empty},
                              problem.outline(),
                              circulation={a.id for a in layout.circulation_spaces},
                              obstacles=[o.to_box() for o in problem.obstacles])
        elements = [self.rooted(
            "IfcWall", f"{_kind(w)}: {' / '.join(w.spaces)}",
            "SOLIDWALL" if w.exterior else "PARTITIONING") for w in walls]
        by_wall = {id(w): e for w, e in zip(walls, elements, strict=True)}
        openings: list[tuple[Any, WallSegment, Segment, float, float]] = []
        for k, (door, wall) in enumerate(zip(
                layout.doors, walls_of(walls, [d.segment for d in layout.doors]), strict=True)):
            if wall is not None:
                name = f"door {k + 1}: {' / '.join(door.between)}"
                openings.append((self.rooted("IfcDoor", name, "DOOR"), wall, door.segment,
                                 0.0, DOOR_HEIGHT))
        for k, (window, wall) in enumerate(zip(
                layout.windows, walls_of(walls, [w.segment for w in layout.windows]),
                strict=True)):
            if wall is not None:
                name = f"window {k + 1}: {window.room}"
                openings.append((self.rooted("IfcWindow", name, "WINDOW"), wall,
                                 window.segment, SILL_HEIGHT, WINDOW_HEIGHT))
        obstacles = [(self.rooted("IfcColumn" if COLUMN_LABEL.search(o.label)
                                  else "IfcBuildingElementProxy", o.label), o)
                     for o in problem.obstacles]
        ifcopenshell.api.spatial.assign_container(
            self.file, relating_structure=storey,
            products=[*elements, *(e for e, *_ in openings), *(e for e, _ in obstacles)])

        for wall, element in zip(walls, elements, strict=True):
            self.wall(storey, wall, element, [spaces[s] for s in wall.spaces])
        for exterior in (True, False):
            self.share_pset([e for w, e in zip(walls, elements, strict=True)
                             if w.exterior is exterior], "Pset_WallCommon",
                            {"IsExternal": exterior, "Reference": "facade" if exterior
                             else "partition"})
        for element, wall, segment, sill, height in openings:
            self.opening(element, wall, by_wall[id(wall)], segment, sill, height)
        for element, obstacle in obstacles:
            self.extruded(element, storey, obstacle.to_box(), self.height)

    def rooted(self, ifc_class: str, name: str, predefined_type: str | None = None,
               **attributes: Any) -> Any:
        """A new occurrence of `ifc_class` with its GlobalId. (As the API's
        root.create_entity makes it, less the owner history, which IFC4 leaves
        optional and the API looks up at a millisecond an element.)"""
        if predefined_type is not None:
            attributes["PredefinedType"] = predefined_type
        return self.file.create_entity(ifc_class, GlobalId=ifcopenshell.guid.new(), Name=name,
                                       **attributes)

    def wall(self, storey: Any, wall: WallSegment, element: Any, spaces: Sequence[Any]) -> None:
        """The wall's body and placement, and its boundaries with `spaces`."""
        representation = ifcopenshell.api.geometry.add_wall_representation(
            self.file, context=self.body, length=wall.length, height=self.height,
            offset=wall.offset, thickness=wall.thickness)
        ifcopenshell.api.geometry.assign_representation(
            self.file, product=element, representation=representation)
        element.ObjectPlacement = self.placement(
            storey.ObjectPlacement, (*wall.start, 0.0), wall.direction)
        self.boundaries(spaces, element, wall)

    def share_pset(self, products: list[Any], name: str, properties: dict[str, Any]) -> None:
        """One property set `name` holding `properties` for all of `products`."""
        if not products:
            return
        pset = ifcopenshell.api.pset.add_pset(self.file, product=products[0], name=name)
        ifcopenshell.api.pset.edit_pset(self.file, pset=pset, properties=properties)
        if products[1:]:
            ifcopenshell.api.pset.assign_pset(self.file, products=products[1:], pset=pset)

    def boundaries(self, spaces: Sequence[Any], element: Any, wall: WallSegment) -> None:
        """Each space bounded by the wall, along the face they share (a first-level
        boundary: the edge of the space's footprint, up the storey's height). Every
        space sits at its storey's origin, so the spaces either side of a partition
        share one face."""
        geometry = None
        for space in spaces:
            rel = self.file.create_entity(
                "IfcRelSpaceBoundary", GlobalId=ifcopenshell.guid.new(), RelatingSpace=space,
                RelatedBuildingElement=element, PhysicalOrVirtualBoundary="PHYSICAL",
                InternalOrExternalBoundary="EXTERNAL" if wall.exterior else "INTERNAL")
            if geometry is None:
                (x0, y0), (x1, y1) = wall.edge
                length = math.dist(wall.edge[0], wall.edge[1])
                dx, dy = (x1 - x0) / length, (y1 - y0) / length
                ifcopenshell.api.boundary.assign_connection_geometry(
                    self.file, rel_space_boundary=rel,
                    outer_boundary=[(0.0, 0.0), (length, 0.0), (length, self.height),
                                    (0.0, self.height)],
                    location=(x0, y0, 0.0), axis=(dy, -dx, 0.0), ref_direction=(dx, dy, 0.0),
                    unit_scale=1.0)
                geometry = rel.ConnectionGeometry
            else:
                rel.ConnectionGeometry = geometry

    def opening(self, element: Any, wall: WallSegment, wall_element: Any, segment: Segment,
                sill: float, height: float) -> None:
        """The door or window `element`, `segment` wide, filling an opening through
        `wall` from `sill` up `height`."""
        u0, u1 = sorted((wall.along(segment[0]), wall.along(segment[1])))
        width = u1 - u0
        door = element.is_a("IfcDoor")
        opening = self.rooted("IfcOpeningElement", element.Name, "OPENING")
        depth = wall.thickness + 2 * OPENING_MARGIN
        self.body_of(opening, self.solid(self.builder.rectangle(size=(width, depth)), height,
                                         at=(0.0, wall.offset - OPENING_MARGIN, 0.0)))
        ifcopenshell.api.feature.add_feature(self.file, feature=opening, element=wall_element)
        opening.ObjectPlacement = self.placement(wall_element.ObjectPlacement, (u0, 0.0, sill))
        element.OverallWidth = width
        element.OverallHeight = height
        if door:
            element.OperationType = "SINGLE_SWING_LEFT"
        else:
            element.PartitioningType = "SINGLE_PANEL"
        ifcopenshell.api.type.assign_type(
            self.file, related_objects=[element],
            relating_type=self.type_of(element.is_a(), width, height, wall.thickness))
        ifcopenshell.api.feature.add_filling(self.file, opening=opening, element=element)
        # The frame spans the wall from its face on the right of the axis.
        element.ObjectPlacement = self.placement(opening.ObjectPlacement,
                                                 (0.0, wall.offset, 0.0))

    def type_of(self, ifc_class: str, width: float, height: float, depth: float) -> Any:
        """The door or window type of this size (made the first time it is asked for),
        with its shape: frame, leaf or pane as ifcopenshell draws them."""
        key = (ifc_class, round(width, 3), round(height, 3), round(depth, 3))
        if key in self.types:
            return self.types[key]
        door = ifc_class == "IfcDoor"
        name = f"{'door' if door else 'window'} {width * 100:.0f} x {height * 100:.0f} cm, " \
            f"wall {depth * 100:.0f} cm"
        kind = ifcopenshell.api.root.create_entity(
            self.file, ifc_class=f"{ifc_class}Type", name=name,
            predefined_type="DOOR" if door else "WINDOW")
        lining = {"LiningDepth": depth}
        if door:
            kind.OperationType = "SINGLE_SWING_LEFT"
            representation = ifcopenshell.api.geometry.add_door_representation(
                self.file, context=self.body, overall_height=height, overall_width=width,
                operation_type="SINGLE_SWING_LEFT", lining_properties=lining)
        else:
            kind.PartitioningType = "SINGLE_PANEL"
            representation = ifcopenshell.api.geometry.add_window_representation(
                self.file, context=self.body, overall_height=height, overall_width=width,
                partition_type="SINGLE_PANEL", lining_properties=lining)
        ifcopenshell.api.geometry.assign_representation(
            self.file, product=kind, representation=representation)
        ifcopenshell.api.project.assign_declaration(
            self.file, definitions=[kind], relating_context=self.file.by_type("IfcProject")[0])
        self.types[key] = kind
        return kind

    def extruded(self, product: Any, storey: Any, shape: Polygon, height: float) -> None:
        """`shape` (in the storey's frame) extruded `height` up as the body of
        `product`, placed on `storey`."""
        product.ObjectPlacement = self.placement(storey.ObjectPlacement, (0.0, 0.0, 0.0))
        ring = list(shape.exterior.coords)[:-1]
        self.body_of(product, self.solid(self.builder.polyline(ring, closed=True), height))

    def solid(self, outline: Any, height: float, at: tuple[float, float, float] = (0, 0, 0),
              ) -> Any:
        """The closed curve `outline` extruded `height` up from `at`. (ShapeBuilder's
        `profile` checks the curve's dimension through the EXPRESS rules, a
        millisecond a profile: made here at once.)"""
        profile = self.file.createIfcArbitraryClosedProfileDef("AREA", None, outline)
        return self.builder.extrude(profile, magnitude=height, position=at)

    def body_of(self, product: Any, *items: Any) -> None:
        ifcopenshell.api.geometry.assign_representation(
            self.file, product=product,
            representation=self.builder.get_representation(self.body, list(items)))

    def placement(self, relative_to: Any, origin: tuple[float, float, float],
                  direction: tuple[float, float] = (1.0, 0.0)) -> Any:
        """A local placement at `origin` in the frame of `relative_to`, its x axis along
        `direction` (a unit vector in plan), z up. (The API's edit_object_placement
        derives the same from a world matrix by inverting every parent's, several
        milliseconds a placement.)"""
        f = self.file
        axes = f.createIfcAxis2Placement3D(
            f.createIfcCartesianPoint([float(c) for c in origin]),
            self.direction((0.0, 0.0, 1.0)), self.direction((*direction, 0.0)))
        return f.createIfcLocalPlacement(relative_to, axes)

    def direction(self, ratios: tuple[float, float, float]) -> Any:
        key = tuple(round(r, 9) for r in ratios)
        if key not in self.directions:
            self.directions[key] = self.file.createIfcDirection([float(r) for r in ratios])
        return self.directions[key]



def _kind(wall: WallSegment) -> str:
    return "facade" if wall.exterior else "partition"


def _ratio(value: float) -> float:
    """A direction ratio rounded to 1e-12, so that north 0 or 90 is exactly (0, 1) or
    (1, 0)."""
    return round(value, 12) + 0.0
