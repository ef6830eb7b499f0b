"""Design variants and fixed rooms over HTTP, against a real `floorplan serve` process
(the embedded mode): ``?variant=i`` in every format, a 404 past the last variant, the
Python client's ``job.result(variant=i)``, a bad fixed polygon refused with a 422 naming
its field; and ``floorplan solve --variants -o DIR/``."""

from __future__ import annotations

import copy
import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from floorplan.models import Layout
from floorplan_client import Client, NotFound
from tests.paths import ROOT
from tests.servers import Server

pytestmark = pytest.mark.slow

APARTMENT: dict[str, Any] = json.loads((ROOT / "examples" / "apartment-5.json").read_text())


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("data")).start()
    yield s
    s.stop()


@pytest.fixture(scope="module")
def client(server: Server) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server.url, timeout=60) as c:
        yield c


@pytest.fixture(scope="module")
def job_id(client: httpx.Client) -> str:
    """A job of apartment-5 with three variants asked, ended."""
    problem = copy.deepcopy(APARTMENT)
    problem["options"] = {"time_limit": 5, "variants": 3}
    response = client.post("/v1/layouts", json=problem)
    assert response.status_code == 202, response.text
    job_id = str(response.json()["id"])
    deadline = time.monotonic() + 180
    while (job := client.get(f"/v1/layouts/{job_id}").json())["status"] not in (
            "succeeded", "failed", "canceled"):
        assert time.monotonic() < deadline, job
        time.sleep(0.5)
    assert job["status"] == "succeeded", job
    return job_id


def test_variants_are_served_one_by_one_in_every_format(
        client: httpx.Client, job_id: str) -> None:
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


def test_the_event_stream_announces_the_variants(client: httpx.Client, job_id: str) -> None:
    announced = []
    with client.stream("GET", f"/v1/layouts/{job_id}/events") as stream:
        kind = ""
        for line in stream.iter_lines():
            if line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: ") and kind == "progress":
                data = json.loads(line[6:])
                if data.get("phase") == "variant":
                    announced.append(data["detail"])
    assert announced and all(d.startswith("variant ") for d in announced)


def test_the_client_fetches_variants(server: Server, job_id: str) -> None:
    with Client(server.url) as sdk:
        job = sdk.get(job_id)
        layout = job.wait()
        assert layout.variants is not None and len(layout.variants) >= 2
        second = job.result(variant=1)
        assert second == layout.variants[1]
        svg = job.result("svg", variant=1)
        assert all(room.id in svg for room in second.rooms)
        with pytest.raises(NotFound):
            job.result(variant=11)


def test_the_command_line_writes_one_file_per_variant(tmp_path: Path) -> None:
    out = tmp_path / "variants"
    done = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "solve",
         str(ROOT / "examples" / "apartment-5.json"), "--variants", "2", "--time-limit", "4",
         "-o", f"{out}/", "--svg", f"{out}/", "-q"],
        capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    written = sorted(p.name for p in out.iterdir())
    count = len([n for n in written if n.endswith(".json")])
    assert count >= 1
    assert written == sorted([f"variant-{i}.{ext}" for i in range(1, count + 1)
                              for ext in ("json", "svg")])
    first = Layout.model_validate_json((out / "variant-1.json").read_text())
    assert first.report.valid and first.variants is None
