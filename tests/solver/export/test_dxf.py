"""The DXF drawing on the AIA / NCS layers, read back with ezdxf from real solves of
house-13 and the two-storey example."""

from __future__ import annotations

import io
from collections.abc import Iterator

import ezdxf
import pytest
import shapely
from ezdxf.document import Drawing
from ezdxf.layouts import BaseLayout
from shapely.geometry import LineString, Polygon

from floorplan.models import OUTSIDE, Layout, Problem
from floorplan.models.storeys import floor_view
from floorplan.solver.export import render
from floorplan.solver.export.floors import floor_layout
from tests.paths import EXAMPLES

NCS = {"A-WALL", "A-WALL-PATT", "A-DOOR", "A-GLAZ", "A-AREA", "A-AREA-IDEN", "A-FLOR-OTLN"}


def read(problem: Problem, layout: Layout) -> Drawing:
    return ezdxf.read(io.StringIO(render(problem, layout, "dxf").decode()))


def floors(doc: Drawing, problem: Problem, layout: Layout,
           ) -> Iterator[tuple[BaseLayout, Problem, Layout]]:
    """Each floor's drawing (the modelspace, or the storey's block) with its problem
    and layout."""
    if layout.floors is None:
        yield doc.modelspace(), problem, layout
        return
    for floor in layout.floors:
        yield (doc.blocks.get(f"STOREY-{floor.id.upper()}"), floor_view(problem, floor.id),
               floor_layout(layout, floor.id))


def polygons(space: BaseLayout, layer: str) -> list[Polygon]:
    return [Polygon([p[:2] for p in e.get_points()])
            for e in space.query(f'LWPOLYLINE[layer=="{layer}"]') if e.closed]


def test_the_layers_are_the_ncs_ones_in_metres(solved_case: tuple[Problem, Layout]) -> None:
    doc = read(*solved_case)
    assert doc.units == ezdxf.units.M
    names = {layer.dxf.name for layer in doc.layers}
    assert names >= NCS
    assert not any(name.startswith("ROOM_") for name in names)
    layout = solved_case[1]
    if layout.floors is not None:
        levels = [f"A-FLOR-LEVL-{f.id.upper()}" for f in layout.floors]
        assert set(levels) <= names
        inserts = doc.modelspace().query("INSERT")
        assert [i.dxf.layer for i in inserts] == levels
        assert [i.dxf.insert.z for i in inserts] == [0.0, 3.0]


def test_every_room_outline_is_on_a_area_with_its_label(
    solved_case: tuple[Problem, Layout],
) -> None:
    doc = read(*solved_case)
    for space, _, layout in floors(doc, *solved_case):
        outlines = polygons(space, "A-AREA")
        assert len(outlines) == len(layout.rooms) + len(layout.aisles)
        for room in layout.rooms:
            shape = Polygon(room.polygon)
            assert any(o.equals_exact(shape, 1e-6) or o.normalize().equals_exact(
                shape.normalize(), 1e-6) for o in outlines), room.id
        labels = [e.plain_text() for e in space.query('MTEXT[layer=="A-AREA-IDEN"]')]
        assert sorted(label.split("\n")[0] for label in labels) == sorted(
            r.id for r in layout.rooms)
        assert all(label.endswith(" m²") for label in labels)


def test_walls_have_their_thickness_and_open_at_doors_and_windows(
    solved_case: tuple[Problem, Layout],
) -> None:
    doc = read(*solved_case)
    for space, problem, layout in floors(doc, *solved_case):
        walls = polygons(space, "A-WALL")
        assert walls and all(w.area > 0 for w in walls)
        assert len(space.query('HATCH[layer=="A-WALL-PATT"]')) == len(walls)
        # The facade is closed but for the front door and the windows.
        ring = problem.outline().exterior
        gaps = ring.difference(shapely.union_all(walls).buffer(1e-6))
        front = [d for d in layout.doors if OUTSIDE in d.between]
        assert gaps.length == pytest.approx(
            sum(LineString(d.segment).length for d in front)
            + sum(LineString(w.segment).length for w in layout.windows), abs=1e-3)
        swinging = [d for d in layout.doors if d.opens_into]
        assert len(space.query('ARC[layer=="A-DOOR"]')) == len(swinging)
        assert len(space.query('LINE[layer=="A-DOOR"]')) == len(swinging)
        assert len(polygons(space, "A-GLAZ")) == len(layout.windows)


def test_user_text_reads_back_as_written_in_dxf_and_ifc() -> None:
    """Room ids are user input: formatting codes, quotes, control characters and any
    script come back as text, in the DXF's labels and the IFC's names."""
    import ifcopenshell
    import ifcopenshell.validate

    problem = Problem.model_validate_json((EXAMPLES / "apartment-5.json").read_text())
    layout = Layout.model_validate_json((EXAMPLES / "apartment-5.layout.json").read_text())
    odd = "wc \\P {x} 'q' \"d\" \x01 été 浴室"
    first = layout.rooms[0].model_copy(update={"id": odd})
    layout = layout.model_copy(update={"rooms": [first, *layout.rooms[1:]]})
    doc = read(problem, layout)
    labels = [e.plain_text() for e in doc.modelspace().query('MTEXT[layer=="A-AREA-IDEN"]')]
    assert odd.replace("\x01", " ") in [label.split("\n")[0] for label in labels]
    model = ifcopenshell.file.from_string(render(problem, layout, "ifc").decode())
    assert odd in {s.Name for s in model.by_type("IfcSpace")}
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(model, logger)
    assert logger.statements == []
