"""GeoJSON and DXF exports, read back with the tools a user would open them in."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import ezdxf
import ifcopenshell
import pytest
from shapely.geometry import shape

from floorplan.models import Layout, Problem
from floorplan.models.formats import ExportOptions
from floorplan.solver.export import render
from floorplan.solver.export.geojson import to_geojson
from tests.paths import EXAMPLES


@pytest.fixture(scope="module")
def example() -> tuple[Problem, Layout]:
    problem = Problem.model_validate_json((EXAMPLES / "house-13.json").read_text())
    layout = Layout.model_validate_json((EXAMPLES / "house-13.layout.json").read_text())
    return problem, layout


def test_geojson_has_a_valid_polygon_per_room_with_its_properties(
    example: tuple[Problem, Layout],
) -> None:
    problem, layout = example
    collection = json.loads(render(problem, layout, "geojson"))
    assert collection["type"] == "FeatureCollection"
    rooms = [f for f in collection["features"] if f["properties"]["kind"] == "room"]
    assert {f["properties"]["id"] for f in rooms} == {r.id for r in layout.rooms}
    for feature in rooms:
        ring = feature["geometry"]["coordinates"][0]
        assert ring[0] == ring[-1]  # closed, as RFC 7946 requires
        polygon = shape(feature["geometry"])
        assert polygon.is_valid and polygon.exterior.is_ccw
        room = next(r for r in layout.rooms if r.id == feature["properties"]["id"])
        assert polygon.area == pytest.approx(room.area, rel=1e-6)
        assert feature["properties"]["type"] == room.type
    kinds = {f["properties"]["kind"] for f in collection["features"]}
    assert {"outline", "room"} <= kinds
    # RFC 7946 removed `crs`: without an origin the coordinates are the plan's metres.
    assert "crs" not in collection


def test_geojson_carries_doors_and_windows_as_lines(example: tuple[Problem, Layout]) -> None:
    problem, layout = example
    layout = Layout.model_validate({
        **layout.model_dump(),
        "doors": [{"between": ["living", "dining"], "segment": [[5, 1], [5, 1.9]]}],
        "windows": [{"room": "living", "segment": [[1, 0], [2.2, 0]]}],
    })
    features = to_geojson(problem, layout)["features"]
    door = next(f for f in features if f["properties"]["kind"] == "door")
    assert door["geometry"] == {"type": "LineString", "coordinates": [[5, 1], [5, 1.9]]}
    assert any(f["properties"]["kind"] == "window" for f in features)


def test_dxf_by_room_type_opens_in_ezdxf_with_a_layer_per_room_type(
    example: tuple[Problem, Layout],
) -> None:
    problem, layout = example
    doc = ezdxf.read(io.StringIO(render(problem, layout, "dxf",
                                        ExportOptions(dxf_layers="room-type")).decode()))
    assert doc.units == ezdxf.units.M
    msp = doc.modelspace()
    polylines = [e for e in msp if e.dxftype() == "LWPOLYLINE"]
    assert all(p.closed for p in polylines)
    room_layers = {p.dxf.layer for p in polylines if p.dxf.layer.startswith("ROOM_")}
    assert room_layers == {f"ROOM_{r.type.upper()}" for r in layout.rooms}
    assert len([p for p in polylines if p.dxf.layer.startswith("ROOM_")]) == len(layout.rooms)
    labels = [e.dxf.text for e in msp if e.dxftype() == "TEXT"]
    assert any(label.startswith("living ") for label in labels)
    assert {"OUTLINE", "DOORS", "WINDOWS"} <= {layer.dxf.name for layer in doc.layers}


@pytest.mark.slow
def test_the_command_line_writes_the_format_its_output_asks_for(tmp_path: Path) -> None:
    # The file's format is under test, not the layout: one second a solve.
    out = tmp_path / "plan.dxf"
    done = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "solve", str(EXAMPLES / "apartment-5.json"),
         "-o", str(out), "--time-limit", "1", "--quiet"], capture_output=True, text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert ezdxf.readfile(out).modelspace()
    geo = tmp_path / "plan.json"
    done = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "solve", str(EXAMPLES / "apartment-5.json"),
         "-o", str(geo), "--format", "geojson", "--time-limit", "1", "--quiet"],
        capture_output=True, text=True, timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(geo.read_text())["type"] == "FeatureCollection"
    ifc = tmp_path / "plan.ifc"
    done = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "solve", str(EXAMPLES / "apartment-5.json"),
         "-o", str(ifc), "--storey-height", "2.8", "--time-limit", "1", "--quiet"],
        capture_output=True, text=True, timeout=60,
    )
    assert done.returncode == 0, done.stderr
    model = ifcopenshell.open(str(ifc))
    assert len(model.by_type("IfcSpace")) == 5
    assert model.by_type("IfcWall")[0].Representation.Representations[0].Items[0].Depth == 2.8


def test_every_output_format_has_a_writer() -> None:
    from floorplan.models.formats import FORMAT_NAMES
    from floorplan.solver.export import WRITERS

    assert tuple(WRITERS) == FORMAT_NAMES
