"""A job's result in every format, by its own operation (/result/svg, ...) and by the
older /result?format= (the same bytes), and GeoJSON's `origin` option, against a real
server process."""

from __future__ import annotations

import re
from collections.abc import Iterator

import httpx2 as httpx
import pytest
from pyproj import Geod
from shapely.geometry import shape

from floorplan.models.formats import MEDIA_TYPES, RENDERED_FORMAT_NAMES
from tests.servers import Server
from tests.service.test_service import SMALL, submit, wait

#: End to end (a real server and a solve).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def solved(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[httpx.Client, str]]:
    server = Server(tmp_path_factory.mktemp("data"), WORKERS="1").start()
    try:
        with httpx.Client(base_url=server.url, timeout=60) as client:
            job = submit(client, SMALL)
            assert wait(client, job["id"], timeout=120)["status"] == "succeeded"
            yield client, job["id"]
    finally:
        server.stop()


def test_each_format_has_its_operation_and_the_old_spelling_answers_the_same(
        solved: tuple[httpx.Client, str]) -> None:
    client, job_id = solved
    for fmt in RENDERED_FORMAT_NAMES:
        own = client.get(f"/v1/layouts/{job_id}/result/{fmt}")
        old = client.get(f"/v1/layouts/{job_id}/result", params={"format": fmt})
        assert own.status_code == old.status_code == 200, fmt
        assert own.headers["content-type"].split(";")[0] == MEDIA_TYPES[fmt]
        assert _drawn(fmt, own.text) == _drawn(fmt, old.text), fmt
    layout = client.get(f"/v1/layouts/{job_id}/result")
    assert layout.headers["content-type"] == "application/json"


def _drawn(fmt: str, body: str) -> object:
    """What a file draws, without what differs between two writings of it: the DXF's
    timestamps (outside its entities), the IFC's fresh GlobalIds (its entities by
    type)."""
    if fmt == "dxf":
        start = body.index("ENTITIES")
        return body[start:body.index("ENDSEC", start)]
    if fmt == "ifc":
        return sorted(re.findall(r"=(IFC[A-Z0-9]+)\(", body))
    return body


def test_geojson_in_wgs84_with_an_origin_by_either_spelling(
        solved: tuple[httpx.Client, str]) -> None:
    client, job_id = solved
    local = client.get(f"/v1/layouts/{job_id}/result/geojson").json()
    assert "crs" not in local
    placed = client.get(f"/v1/layouts/{job_id}/result/geojson",
                        params={"origin": "-33.8568,151.2153"}).json()
    assert "crs" not in placed
    outline = shape(next(f["geometry"] for f in placed["features"]
                         if f["properties"]["kind"] == "outline"))
    west, south, east, north = outline.bounds
    # SMALL is 6 m by 4 m from (0, 0), measured on the ellipsoid.
    assert (west, south) == pytest.approx((151.2153, -33.8568), abs=1e-9)
    geod = Geod(ellps="WGS84")
    assert geod.inv(west, south, east, south)[2] == pytest.approx(6, rel=1e-3)
    assert geod.inv(west, south, west, north)[2] == pytest.approx(4, rel=1e-3)
    old = client.get(f"/v1/layouts/{job_id}/result",
                     params={"format": "geojson", "origin": "-33.8568,151.2153"}).json()
    assert old == placed
    bad = client.get(f"/v1/layouts/{job_id}/result/geojson", params={"origin": "95,0"})
    assert bad.status_code == 422
    assert bad.headers["content-type"] == "application/problem+json"
    assert [e["field"] for e in bad.json()["errors"]] == ["origin"]
