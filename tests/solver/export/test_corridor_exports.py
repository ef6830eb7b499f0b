"""Corridors are drawn and exported as circulation floor, like aisles."""

from __future__ import annotations

from floorplan.models import Layout, Problem
from floorplan.solver.export.dxf import to_dxf
from floorplan.solver.export.geojson import to_geojson
from floorplan.solver.export.ifc import to_ifc
from floorplan.solver.export.svg import render_svg

PROBLEM = Problem.model_validate({
    "boundary": [[0, 0], [10, 0], [10, 6], [0, 6]],
    "rooms": [{"id": "a"}, {"id": "b"}],
    "corridors": {"exits": [[0, 3]], "width": 2},
})
RECT = {"x": 0, "y": 2, "width": 10, "depth": 2}
LAYOUT = Layout.model_validate({
    "rooms": [
        {"id": "a", "type": "office", "polygon": [[0, 0], [10, 0], [10, 2], [0, 2]],
         "rectangles": [{"x": 0, "y": 0, "width": 10, "depth": 2}], "area": 20},
        {"id": "b", "type": "office", "polygon": [[0, 4], [10, 4], [10, 6], [0, 6]],
         "rectangles": [{"x": 0, "y": 4, "width": 10, "depth": 2}], "area": 20},
    ],
    "corridors": [{"id": "corridor-1", "polygon": [[0, 2], [10, 2], [10, 4], [0, 4]],
                   "rectangles": [RECT], "area": 20, "width": 2}],
    "doors": [{"between": ["corridor-1", "a"], "segment": [[4, 2], [5, 2]]},
              {"between": ["corridor-1", "b"], "segment": [[4, 4], [5, 4]]}],
    "report": {"coverage": 1.0, "uncovered_area": 0.0},
})


def test_corridors_in_every_format() -> None:
    features = to_geojson(PROBLEM, LAYOUT)["features"]
    assert [f["properties"]["id"] for f in features
            if f["properties"].get("kind") == "corridor"] == ["corridor-1"]
    assert 'data-id="corridor-1"' in render_svg(PROBLEM, LAYOUT)
    assert b"corridor-1" in to_ifc(PROBLEM, LAYOUT)
    bare = LAYOUT.model_copy(update={"corridors": []})
    assert to_dxf(PROBLEM, LAYOUT).count(b"LWPOLYLINE") > to_dxf(PROBLEM, bare).count(
        b"LWPOLYLINE")
