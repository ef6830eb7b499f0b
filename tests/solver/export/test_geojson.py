"""GeoJSON as GIS tools read it (RFC 7946): without an origin, valid geometries in the
plan's local metres and no `crs` member; with an origin, WGS84 longitude and latitude
that geopandas places on the map where the plan is, at its size, north up."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import geopandas
import pytest
from shapely.geometry import Point, shape

from floorplan.models import Layout, Problem
from floorplan.models.formats import ExportOptions
from floorplan.solver.export import render
from floorplan.solver.export.geojson import to_geojson
from tests.paths import EXAMPLES

#: The Brandenburg Gate, roughly: where the plan's (0, 0) is put.
ORIGIN = (52.5163, 13.3777)
#: Metres east and north of ORIGIN: a transverse Mercator projection centred there.
LOCAL = f"+proj=tmerc +lat_0={ORIGIN[0]} +lon_0={ORIGIN[1]} +k=1 +ellps=WGS84 +units=m"


@pytest.fixture(scope="module")
def example() -> tuple[Problem, Layout]:
    problem = Problem.model_validate_json((EXAMPLES / "house-13.json").read_text())
    layout = Layout.model_validate_json((EXAMPLES / "house-13.layout.json").read_text())
    return problem, layout


def test_local_metres_by_default_valid_for_shapely(example: tuple[Problem, Layout]) -> None:
    problem, layout = example
    collection = json.loads(render(problem, layout, "geojson"))
    assert "crs" not in collection
    for feature in collection["features"]:
        geometry = shape(feature["geometry"])
        assert geometry.is_valid, feature["properties"]
    outline = next(f for f in collection["features"] if f["properties"]["kind"] == "outline")
    assert shape(outline["geometry"]).bounds == pytest.approx(_bounds(problem.boundary))


def test_with_an_origin_geopandas_places_the_plan_on_the_map(
        example: tuple[Problem, Layout], tmp_path: Path) -> None:
    problem, layout = example
    path = tmp_path / "plan.geojson"
    path.write_bytes(render(problem, layout, "geojson", ExportOptions(origin=ORIGIN)))
    assert "crs" not in json.loads(path.read_text())
    frame = geopandas.read_file(path)
    assert frame.crs.to_epsg() == 4326  # RFC 7946's WGS84, as every reader takes it
    assert frame.geometry.is_valid.all()
    # Measured on a transverse Mercator map centred on the origin (true to scale
    # there, x east, y north), the plan comes back as it was drawn: its metres, its place.
    metric = frame.to_crs(LOCAL)
    rooms = metric[metric["kind"] == "room"]
    drawn = {f["properties"]["id"]: shape(f["geometry"])
             for f in to_geojson(problem, layout)["features"] if f["properties"]["kind"] == "room"}
    for room_id, geometry in zip(rooms["id"], rooms.geometry, strict=True):
        # Degrees are kept to 8 places (a millimetre): areas within a thousandth.
        assert geometry.area == pytest.approx(drawn[room_id].area, rel=1e-3), room_id
        assert geometry.hausdorff_distance(drawn[room_id]) < 0.005, room_id
    outline = metric[metric["kind"] == "outline"].geometry.iloc[0]
    assert outline.bounds == pytest.approx(_bounds(problem.boundary), abs=0.005)


def test_north_stays_up(example: tuple[Problem, Layout]) -> None:
    problem, layout = example
    layout = Layout.model_validate({
        **layout.model_dump(), "windows": [{"room": "living", "segment": [[1, 0], [3, 0]]}],
        "doors": [{"between": ["living", "dining"], "segment": [[5, 1], [5, 2]]}]})
    features = to_geojson(problem, layout, ORIGIN)["features"]
    window = next(f for f in features if f["properties"]["kind"] == "window")
    (lon_a, lat_a), (lon_b, lat_b) = window["geometry"]["coordinates"]
    assert lat_a == lat_b and lon_b > lon_a  # along x: due east
    door = next(f for f in features if f["properties"]["kind"] == "door")
    (lon_a, lat_a), (lon_b, lat_b) = door["geometry"]["coordinates"]
    assert lon_a == lon_b and lat_b > lat_a  # along y: due north


def test_an_origin_off_the_map_is_refused() -> None:
    with pytest.raises(ValueError, match="latitude"):
        ExportOptions(origin=(95.0, 0.0))


@pytest.mark.slow
def test_the_command_line_writes_wgs84_with_origin(tmp_path: Path) -> None:
    out = tmp_path / "plan.geojson"
    done = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "solve", str(EXAMPLES / "apartment-5.json"),
         "-o", str(out), "--origin", f"{ORIGIN[0]},{ORIGIN[1]}", "--time-limit", "1",
         "--quiet"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    frame = geopandas.read_file(out)
    assert frame.geometry.is_valid.all()
    # The flat is there: within its own size of the origin, in metres.
    assert frame.to_crs(LOCAL).geometry.distance(Point(0, 0)).max() < 30
    refused = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "solve", str(EXAMPLES / "apartment-5.json"),
         "-o", str(out), "--origin", "north pole"], capture_output=True, text=True, timeout=60)
    assert refused.returncode == 2 and "--origin" in refused.stderr


def _bounds(points: list[tuple[float, float]]) -> tuple[float, float, float, float]:
    xs, ys = [x for x, _ in points], [y for _, y in points]
    return min(xs), min(ys), max(xs), max(ys)


def test_a_plan_whose_north_is_plus_x_is_turned_onto_the_map(
        example: tuple[Problem, Layout]) -> None:
    # `north: 90`: true north points along the plan's +x, so the plan's +y points west.
    problem, layout = example
    turned = problem.model_copy(update={"north": 90.0})
    layout = Layout.model_validate({
        **layout.model_dump(), "windows": [{"room": "living", "segment": [[1, 0], [3, 0]]}],
        "doors": [{"between": ["living", "dining"], "segment": [[5, 1], [5, 2]]}]})
    features = to_geojson(turned, layout, ORIGIN)["features"]
    window = next(f for f in features if f["properties"]["kind"] == "window")
    (lon_a, lat_a), (lon_b, lat_b) = window["geometry"]["coordinates"]
    assert lon_a == pytest.approx(lon_b, abs=1e-8) and lat_b > lat_a  # along x: due north
    door = next(f for f in features if f["properties"]["kind"] == "door")
    (lon_a, lat_a), (lon_b, lat_b) = door["geometry"]["coordinates"]
    assert lat_a == pytest.approx(lat_b, abs=1e-8) and lon_b < lon_a  # along y: due west
    # Turning keeps every length: the outline's area on the map is the plan's.
    frame = geopandas.GeoDataFrame.from_features(features, crs="EPSG:4326").to_crs(LOCAL)
    outline = frame[frame["kind"] == "outline"].geometry.iloc[0]
    assert outline.area == pytest.approx(problem.outline().area, rel=1e-3)
