"""Batches over HTTP (/v1/batches), against real service processes on loopback in both
modes (embedded, and an API node with Celery workers on PostgreSQL and Redis): progress,
results paging, cancel, limits, and a restart midway."""

from __future__ import annotations

import io
import json
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from tests.servers import BACKENDS, AnyServer, service
from tests.service.test_service import SMALL

TINY = {**SMALL, "options": {}}


@pytest.fixture(scope="module", params=BACKENDS)
def backend(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def server(backend: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[AnyServer]:
    s = service(backend, tmp_path_factory.mktemp("data")).start()
    yield s
    s.stop()


@pytest.fixture
def client(server: AnyServer) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server.url, timeout=30) as c:
        yield c


def submit_batch(client: httpx.Client, **body: Any) -> dict[str, Any]:
    response = client.post("/v1/batches", json={"problem": TINY, **body})
    assert response.status_code == 202, response.text
    assert response.headers["location"] == f"/v1/batches/{response.json()['id']}"
    return response.json()


def wait_batch(client: httpx.Client, batch_id: str, timeout: float = 120) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        batch = client.get(f"/v1/batches/{batch_id}").json()
        if batch["status"] in {"succeeded", "failed", "canceled"}:
            return batch
        time.sleep(0.2)
    raise AssertionError(f"batch {batch_id} did not finish: {batch}")


def results(client: httpx.Client, batch_id: str, **params: Any) -> tuple[list[dict], str | None]:
    response = client.get(f"/v1/batches/{batch_id}/results", params=params)
    assert response.status_code == 200, response.text
    assert response.headers["content-type"].startswith("application/x-ndjson")
    lines = [json.loads(line) for line in response.text.splitlines()]
    return lines, response.headers.get("link")


@pytest.mark.slow
def test_a_batch_reports_progress_and_pages_its_results(client: httpx.Client) -> None:
    batch = submit_batch(client, count=5, seed=10, time_limit=1)
    assert batch["count"] == 5 and batch["queued"] + batch["running"] + batch["succeeded"] == 5
    done = wait_batch(client, batch["id"])
    assert (done["status"], done["succeeded"], done["failed"]) == ("succeeded", 5, 0)
    summary = client.get(f"/v1/batches/{batch['id']}", params={"summary": "true"}).json()
    assert summary["valid"] == 5 and 1 <= summary["distinct_plans"] <= 5
    first, link = results(client, batch["id"], limit=2)
    assert [line["index"] for line in first] == [0, 1]
    assert [line["seed"] for line in first] == [10, 11]
    assert first[0]["layout"]["report"]["valid"] and first[0]["valid"]
    assert link is not None and "after=1" in link
    rest, link = results(client, batch["id"], after=1, limit=10, layouts="false")
    assert [line["index"] for line in rest] == [2, 3, 4]
    assert link is None and all("layout" not in line for line in rest)
    # A layout's export needs its problem, which the store derives from the batch's
    # brief (stored once): the plan's rooms are the brief's.
    svg = client.get(f"/v1/layouts/{rest[0]['job_id']}/result/svg")
    assert svg.status_code == 200, svg.text
    assert all(room["id"] in svg.text for room in TINY["rooms"])


def test_cancel_stops_what_is_left(client: httpx.Client) -> None:
    batch = submit_batch(client, count=40, time_limit=2)
    canceled = client.post(f"/v1/batches/{batch['id']}/cancel")
    assert canceled.status_code == 200
    done = wait_batch(client, batch["id"])
    assert done["status"] == "canceled" and done["canceled"] > 0
    assert done["succeeded"] + done["canceled"] + done["failed"] == 40


def test_an_invalid_brief_or_count_is_refused(client: httpx.Client) -> None:
    bad = client.post("/v1/batches", json={"problem": {**TINY, "rooms": []}, "count": 2})
    assert bad.status_code == 422
    assert client.post("/v1/batches", json={"problem": TINY, "count": 0}).status_code == 422
    assert client.get("/v1/batches/00000000-0000-0000-0000-000000000000").status_code == 404


@pytest.mark.slow
def test_a_batch_larger_than_the_queue_is_refused(backend: str, tmp_path: Path) -> None:
    s = service(backend, tmp_path, FLOORPLAN_QUEUE_LIMIT="3").start()
    try:
        with httpx.Client(base_url=s.url, timeout=30) as c:
            refused = c.post("/v1/batches", json={"problem": TINY, "count": 4})
            assert refused.status_code == 429 and refused.headers["retry-after"]
            assert c.post("/v1/batches", json={"problem": TINY, "count": 3}).status_code == 202
    finally:
        s.stop()


@pytest.mark.slow
def test_batches_of_other_keys_are_hidden(backend: str, tmp_path: Path) -> None:
    s = service(backend, tmp_path, FLOORPLAN_API_KEYS="alpha, beta").start()
    try:
        with httpx.Client(base_url=s.url, timeout=30) as c:
            alpha = {"Authorization": "Bearer alpha"}
            made = c.post("/v1/batches", json={"problem": TINY, "count": 1}, headers=alpha)
            assert made.status_code == 202
            assert c.get(f"/v1/batches/{made.json()['id']}",
                         headers={"X-API-Key": "beta"}).status_code == 404
            assert c.post("/v1/batches", json={"problem": TINY, "count": 1}).status_code == 401
    finally:
        s.stop()


@pytest.mark.slow
def test_a_restart_midway_loses_nothing_and_repeats_nothing(backend: str,
                                                             tmp_path: Path) -> None:
    first = service(backend, tmp_path).start()
    with httpx.Client(base_url=first.url, timeout=30) as c:
        batch = submit_batch(c, count=12, time_limit=1)
        deadline = time.monotonic() + 120
        while c.get(f"/v1/batches/{batch['id']}").json()["succeeded"] < 3:
            assert time.monotonic() < deadline
            time.sleep(0.1)
        before, _ = results(c, batch["id"], limit=500)
    first.kill()
    second = service(backend, tmp_path).start()
    try:
        with httpx.Client(base_url=second.url, timeout=30) as c:
            done = wait_batch(c, batch["id"], timeout=180)
            assert (done["succeeded"], done["failed"]) == (12, 0)
            after, _ = results(c, batch["id"], limit=500)
            assert [line["index"] for line in after] == list(range(12))
            kept = {line["index"]: line for line in after}
            for line in before:  # done before the kill: the same job, not solved again
                if line["status"] == "succeeded":
                    assert kept[line["index"]]["job_id"] == line["job_id"]
                    assert kept[line["index"]]["layout"] == line["layout"]
            attempts = [c.get(f"/v1/layouts/{line['job_id']}").json()["attempts"]
                        for line in after]
            assert all(a <= 2 for a in attempts) and attempts.count(1) >= 3
    finally:
        second.stop()


@pytest.mark.slow
def test_the_client_and_floorplan_submit_make_and_read_batches(server: AnyServer,
                                                                tmp_path: Path) -> None:
    import subprocess
    import sys

    from floorplan_client import BatchLine, Client
    from tests.service.test_cli import _env

    with Client(server.url) as fp:
        batch = fp.submit_batch(TINY, 3, seed=5, time_limit=1)
        deadline = time.monotonic() + 120
        while not fp.get_batch(batch.id).status.terminal:
            assert time.monotonic() < deadline
            time.sleep(0.2)
        lines = list(fp.batch_results(batch.id, page_size=2))
        assert [line.seed for line in lines] == [5, 6, 7]
        assert all(isinstance(line, BatchLine) and line.layout is not None for line in lines)
        assert fp.get_batch(batch.id, summary=True).valid == 3
        # The same page as a zip: a file per layout and the page's lines.
        archive = zipfile.ZipFile(io.BytesIO(fp.batch_zip(batch.id, page_size=2)))
        names = archive.namelist()
        assert "results.ndjson" in names and len(names) == 3, names
        assert len(archive.read("results.ndjson").decode().splitlines()) == 2
    brief = tmp_path / "tiny.json"
    brief.write_text(json.dumps(TINY))
    done = subprocess.run(
        [sys.executable, "-m", "floorplan.service", "submit", str(brief), "--server", server.url,
         "--count", "2", "--time-limit", "1", "--out", str(tmp_path / "out")],
        capture_output=True, text=True, timeout=180, env=_env())
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "two-rooms-000000.json", "two-rooms-000001.json"]
    assert "2 valid" in done.stderr


@pytest.mark.slow
def test_a_batch_keeps_to_the_key_s_quota_and_the_service_s_limits(tmp_path: Path) -> None:
    # The limits (docs/security.md) hold for batches as for single jobs: a batch is that
    # many jobs of its key, and its brief gets the checks of any body (here the
    # outline's extent).
    s = service("embedded", tmp_path, FLOORPLAN_MAX_JOBS_PER_KEY="2").start()
    try:
        with httpx.Client(base_url=s.url, timeout=30) as c:
            over = c.post("/v1/batches", json={"problem": TINY, "count": 3})
            assert over.status_code == 429 and over.headers["retry-after"]
            assert "FLOORPLAN_MAX_JOBS_PER_KEY" in over.json()["detail"]
            side = 20_000
            huge = {**TINY, "boundary": [[0, 0], [side, 0], [side, side], [0, side]]}
            wide = c.post("/v1/batches", json={"problem": huge, "count": 1})
            assert wide.status_code == 422, wide.text
            assert "boundary" in wide.text
            assert c.post("/v1/batches", json={"problem": TINY, "count": 2}).status_code == 202
    finally:
        s.stop()


FLAT_7 = json.loads((Path(__file__).resolve().parents[2] / "examples/flat-7-template.json")
                    .read_text())


@pytest.mark.slow
def test_results_come_as_a_zip_of_layouts_paged_and_programmes_vary(
        client: httpx.Client, backend: str) -> None:
    if backend == "celery":
        pytest.skip("the zip is made by the API node from the store, as in the embedded mode")

    # 4 s a layout, each stopped at its first good one: at 2 s a loaded machine failed one.
    made = client.post("/v1/batches", json={"problem": FLAT_7, "count": 2, "seed": 0,
                                            "time_limit": 4, "vary_program": True})
    assert made.status_code == 202, made.text
    batch = made.json()
    assert wait_batch(client, batch["id"])["succeeded"] == 2
    page = client.get(f"/v1/batches/{batch['id']}/results",
                      params={"format": "zip", "limit": 1})
    assert page.status_code == 200 and page.headers["content-type"] == "application/zip"
    assert "attachment" in page.headers["content-disposition"]
    assert "after=0" in page.headers["link"]
    archive = zipfile.ZipFile(io.BytesIO(page.content))
    assert sorted(archive.namelist()) == ["flat-7-template-000000.json", "results.ndjson"]
    first = json.loads(archive.read("flat-7-template-000000.json"))
    (line,) = [json.loads(x) for x in archive.read("results.ndjson").splitlines()]
    assert line["index"] == 0 and "layout" not in line and line["status"] == "succeeded"
    # The next page, asked for by the Accept header as a browser or curl would.
    rest = client.get(f"/v1/batches/{batch['id']}/results", params={"after": 0},
                      headers={"Accept": "application/zip"})
    assert rest.status_code == 200 and "link" not in rest.headers
    second = json.loads(zipfile.ZipFile(io.BytesIO(rest.content))
                        .read("flat-7-template-000001.json"))
    # Seeds 0 and 1 draw programmes of 7 and 6 rooms from the template (models.programme).
    assert {len(first["rooms"]), len(second["rooms"])} == {6, 7}
    bad = client.get(f"/v1/batches/{batch['id']}/results", params={"format": "tar"})
    assert bad.status_code == 422 and "format" in bad.text
