"""Design variants and fixed rooms over HTTP (issue 21), against a real `floorplan
serve` process (the embedded mode): ``?variant=i`` in every format, a 404 past the
last variant, and a bad fixed polygon refused with a 422 naming its field."""

from __future__ import annotations

import copy
import json
import time
from collections.abc import Iterator
from typing import Any

import httpx2 as httpx
import pytest

from tests.paths import ROOT
from tests.servers import Server

pytestmark = pytest.mark.slow

APARTMENT: dict[str, Any] = json.loads((ROOT / "examples" / "apartment-5.json").read_text())


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[httpx.Client]:
    server = Server(tmp_path_factory.mktemp("data")).start()
    try:
        with httpx.Client(base_url=server.url, timeout=60) as c:
            yield c
    finally:
        server.stop()


def test_variants_are_served_one_by_one_in_every_format(client: httpx.Client) -> None:
    problem = copy.deepcopy(APARTMENT)
    problem["options"] = {"time_limit": 10, "variants": 3}
    response = client.post("/v1/layouts", json=problem)
    assert response.status_code == 202, response.text
    job_id = response.json()["id"]
    deadline = time.monotonic() + 180
    while (job := client.get(f"/v1/layouts/{job_id}").json())["status"] not in (
            "succeeded", "failed", "canceled"):
        assert time.monotonic() < deadline, job
        time.sleep(0.5)
    assert job["status"] == "succeeded", job
    layout = client.get(f"/v1/layouts/{job_id}/result").json()
    variants = layout["variants"]
    assert len(variants) >= 2
    first = client.get(f"/v1/layouts/{job_id}/result", params={"variant": 0}).json()
    assert first["rooms"] == layout["rooms"] and first["variants"] is None
    second = client.get(f"/v1/layouts/{job_id}/result", params={"variant": 1}).json()
    assert second == variants[1]
    assert second["report"]["variant"]["index"] == 1
    assert second["report"]["objective"] >= first["report"]["objective"]
    svg = client.get(f"/v1/layouts/{job_id}/result", params={"variant": 1, "format": "svg"})
    assert svg.status_code == 200 and svg.text.lstrip().startswith("<")
    assert all(room["id"] in svg.text for room in second["rooms"])
    for fmt in ("geojson", "dxf"):
        drawn = client.get(f"/v1/layouts/{job_id}/result", params={"variant": 1, "format": fmt})
        assert drawn.status_code == 200, drawn.text
    missing = client.get(f"/v1/layouts/{job_id}/result", params={"variant": 11})
    assert missing.status_code == 404
    assert missing.headers["content-type"].startswith("application/problem+json")
    assert client.get(f"/v1/layouts/{job_id}/result",
                      params={"variant": 12}).status_code == 422


def test_a_fixed_room_outside_the_outline_is_a_422_naming_the_field(
        client: httpx.Client) -> None:
    problem = copy.deepcopy(APARTMENT)
    problem["rooms"][2]["fixed"] = [[8, 6], [12, 6], [12, 8], [8, 8]]
    response = client.post("/v1/layouts", json=problem)
    assert response.status_code == 422
    assert response.headers["content-type"].startswith("application/problem+json")
    fields = [e["field"] for e in response.json()["errors"]]
    assert fields == ["rooms.2.fixed"]
