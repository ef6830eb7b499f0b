"""The IFC4 export, read back with ifcopenshell from real solves of house-13 (the bench
case) and the two-storey example."""

from __future__ import annotations

import functools
from collections import Counter
from dataclasses import dataclass

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.element
import ifcopenshell.util.placement
import ifcopenshell.util.shape
import ifcopenshell.validate
import pytest
from shapely.geometry import LineString, Point

from floorplan.models import Layout, Problem
from floorplan.solver.export import render
from floorplan.solver.export.ifc import DOOR_HEIGHT, to_ifc
from floorplan.solver.export.walls import FACADE_THICKNESS
from tests.paths import EXAMPLES
from tests.solver.export.conftest import CASES_READ_BACK, solved

#: The NetFloorArea of a space, and the area of its shape, may differ from the
#: layout's area of the room by this share at most.
AREA_TOLERANCE = 0.01


@dataclass(frozen=True)
class Exported:
    problem: Problem
    layout: Layout
    model: ifcopenshell.file


@functools.cache
def export(name: str) -> Exported:
    problem, layout = solved(name)
    text = render(problem, layout, "ifc").decode()
    return Exported(problem, layout, ifcopenshell.file.from_string(text))


@pytest.fixture(params=CASES_READ_BACK)
def exported(request: pytest.FixtureRequest) -> Exported:
    return export(request.param)


def floors_of(e: Exported) -> list[tuple[str, Layout | object]]:
    """(storey name, that floor's layout) for each storey the layout has."""
    if e.layout.floors is None:
        return [(e.problem.name, e.layout)]
    return [(f.name, f) for f in e.layout.floors]


def test_one_storey_per_floor_at_its_elevation(exported: Exported) -> None:
    storeys = exported.model.by_type("IfcBuildingStorey")
    floors = floors_of(exported)
    assert [s.Name for s in storeys] == [name for name, _ in floors]
    assert [s.Elevation for s in storeys] == [3.0 * k for k in range(len(floors))]
    project, = exported.model.by_type("IfcProject")
    units = {u.UnitType: u for u in project.UnitsInContext.Units}
    assert units["LENGTHUNIT"].Name == "METRE" and units["LENGTHUNIT"].Prefix is None
    site, = exported.model.by_type("IfcSite")
    building, = exported.model.by_type("IfcBuilding")
    assert site.Decomposes[0].RelatingObject == project
    assert building.Decomposes[0].RelatingObject == site
    assert all(s.Decomposes[0].RelatingObject == building for s in storeys)


def test_one_space_per_room_with_its_area_type_and_quantities(exported: Exported) -> None:
    spaces = exported.model.by_type("IfcSpace")
    vertical = {v.id for v in exported.problem.vertical}
    rooms = {(r.id if r.id in vertical else (floor, r.id)): r
             for floor, f in floors_of(exported) for r in f.rooms}  # type: ignore[attr-defined]
    assert len(spaces) == len(rooms)
    assert Counter(s.Name for s in spaces) == Counter(
        key if isinstance(key, str) else key[1] for key in rooms)
    settings = ifcopenshell.geom.settings()
    for space in spaces:
        storey = ifcopenshell.util.element.get_container(space) or space.Decomposes[0] \
            .RelatingObject
        room = rooms[space.Name if space.Name in vertical else (storey.Name, space.Name)]
        assert space.LongName == room.type and space.ObjectType == room.type
        qto = ifcopenshell.util.element.get_psets(space)["Qto_SpaceBaseQuantities"]
        assert qto["NetFloorArea"] == pytest.approx(room.area, rel=AREA_TOLERANCE)
        assert qto["GrossPerimeter"] > 0 and qto["Height"] >= 3.0
        shape = ifcopenshell.geom.create_shape(settings, space)
        footprint = ifcopenshell.util.shape.get_footprint_area(shape.geometry)
        assert footprint == pytest.approx(room.area, rel=AREA_TOLERANCE), space.Name


def test_a_vertical_room_is_one_space_through_its_storeys(exported: Exported) -> None:
    if not exported.problem.vertical:
        pytest.skip("one storey")
    stairs, = [s for s in exported.model.by_type("IfcSpace") if s.Name == "stairs"]
    ground, upper = exported.model.by_type("IfcBuildingStorey")
    assert stairs.Decomposes[0].RelatingObject == ground
    # IFC4 gives spaces no inverse attribute for it: the relationship names them.
    references = exported.model.by_type("IfcRelReferencedInSpatialStructure")
    assert [rel.RelatingStructure for rel in references if stairs in rel.RelatedElements] \
        == [upper]
    assert ifcopenshell.util.element.get_psets(stairs)["Qto_SpaceBaseQuantities"][
        "Height"] == pytest.approx(6.0)


def test_every_door_and_window_fills_an_opening_in_a_wall(exported: Exported) -> None:
    doors = [d for _, f in floors_of(exported) for d in f.doors]  # type: ignore[attr-defined]
    windows = [w for _, f in floors_of(exported) for w in f.windows]  # type: ignore[attr-defined]
    ifc_doors = exported.model.by_type("IfcDoor")
    ifc_windows = exported.model.by_type("IfcWindow")
    assert len(ifc_doors) == len(doors) and len(ifc_windows) == len(windows)
    widths = sorted(round(abs(complex(*d.segment[1]) - complex(*d.segment[0])), 3)
                    for d in doors)
    assert sorted(round(d.OverallWidth, 3) for d in ifc_doors) == widths
    assert all(d.OverallHeight == DOOR_HEIGHT for d in ifc_doors)
    for element in [*ifc_doors, *ifc_windows]:
        opening = element.FillsVoids[0].RelatingOpeningElement
        assert opening.VoidsElements[0].RelatingBuildingElement.is_a("IfcWall")
        assert ifcopenshell.util.element.get_container(element) is not None
        assert ifcopenshell.util.element.get_type(element) is not None
    # Each door stands where the layout put it: at its segment, through the wall.
    segments = {(name, f"door {k + 1}: {' / '.join(d.between)}"): d.segment
                for name, f in floors_of(exported)
                for k, d in enumerate(f.doors)}  # type: ignore[attr-defined]
    for door in ifc_doors:
        storey = ifcopenshell.util.element.get_container(door)
        x, y, z = ifcopenshell.util.placement.get_local_placement(door.ObjectPlacement)[:3, 3]
        segment = LineString(segments[storey.Name, door.Name])
        assert segment.distance(Point(x, y)) <= FACADE_THICKNESS + 1e-6, door.Name
        assert z == pytest.approx(storey.Elevation)


def test_walls_bound_the_spaces_facade_and_partitions(exported: Exported) -> None:
    walls = exported.model.by_type("IfcWall")
    external = [w for w in walls
                if ifcopenshell.util.element.get_psets(w)["Pset_WallCommon"]["IsExternal"]]
    assert external and len(external) < len(walls)
    assert {w.PredefinedType for w in walls} == {"SOLIDWALL", "PARTITIONING"}
    for space in exported.model.by_type("IfcSpace"):
        bounded_by = [rel.RelatedBuildingElement for rel in space.BoundedBy]
        assert bounded_by and all(w.is_a("IfcWall") for w in bounded_by), space.Name
    # Built once: a partition bounds the two rooms either side of it.
    assert any(len({rel.RelatingSpace for rel in w.ProvidesBoundaries}) == 2 for w in walls)


def test_the_model_validates(exported: Exported) -> None:
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(exported.model, logger)
    assert logger.statements == []


@pytest.mark.slow
def test_the_model_keeps_the_schemas_rules(exported: Exported) -> None:
    """The EXPRESS WHERE rules as well (tens of seconds)."""
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(exported.model, logger, express_rules=True)
    assert logger.statements == []


def test_the_storey_height_is_an_option() -> None:
    problem = Problem.model_validate_json((EXAMPLES / "two-storey-house.json").read_text())
    layout = Layout.model_validate_json((EXAMPLES / "two-storey-house.layout.json").read_text())
    model = ifcopenshell.file.from_string(to_ifc(problem, layout, storey_height=3.5).decode())
    assert [s.Elevation for s in model.by_type("IfcBuildingStorey")] == [0.0, 3.5]
    stairs, = [s for s in model.by_type("IfcSpace") if s.Name == "stairs"]
    assert ifcopenshell.util.element.get_psets(stairs)["Qto_SpaceBaseQuantities"][
        "Height"] == pytest.approx(7.0)
    with pytest.raises(ValueError, match="storey_height"):
        to_ifc(problem, layout, storey_height=2.0)


def test_true_north_is_the_problems() -> None:
    problem = Problem.model_validate_json((EXAMPLES / "apartment-5.json").read_text())
    layout = Layout.model_validate_json((EXAMPLES / "apartment-5.layout.json").read_text())
    for north, direction in ((0.0, (0.0, 1.0)), (90.0, (1.0, 0.0)), (330.0, (-0.5, 0.866))):
        turned = problem.model_copy(update={"north": north})
        model = ifcopenshell.file.from_string(to_ifc(turned, layout).decode())
        context = next(c for c in model.by_type("IfcGeometricRepresentationContext")
                       if not c.is_a("IfcGeometricRepresentationSubContext"))
        assert context.TrueNorth.DirectionRatios == pytest.approx(direction, abs=1e-3)
        logger = ifcopenshell.validate.json_logger()
        ifcopenshell.validate.validate(model, logger)
        assert logger.statements == []
