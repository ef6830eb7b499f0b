"""A client generated from the live server's /openapi.json by openapi-python-client,
as a user of another team would make one, and used alone (its own models, its own
parsing): submit, poll, the JSON result, the SVG plan, the IFC model, the event
stream's first event, a page of a batch's results, a 404 and a 422. What it shows:
each operation declares the one media type it answers in, errors are problem
documents, and keys go through the declared security schemes."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import httpx2 as httpx
import pytest

from tests.paths import ROOT
from tests.servers import Server
from tests.service.test_service import SMALL

#: End to end (a real server, a generated package, real solves).
pytestmark = pytest.mark.slow

KEY = "alpha"
#: What openapi-python-client names the package after the document's title.
PACKAGE = "floorplan_layout_api_client"
#: The generator's settings the repository ships: how to read the service's media types.
CONFIG = ROOT / "clients" / "generated" / "openapi-python-client.yaml"
#: Long enough for the small problems to be solved on a busy machine.
WAIT = 120.0


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("data"), FLOORPLAN_API_KEYS=KEY).start()
    yield s
    s.stop()


@pytest.fixture(scope="module")
def generated(server: Server, tmp_path_factory: pytest.TempPathFactory) -> Iterator[ModuleType]:
    """The package openapi-python-client writes from the live document, imported."""
    where = tmp_path_factory.mktemp("generated")
    spec = where / "openapi.json"
    spec.write_text(httpx.get(f"{server.url}/openapi.json").text, encoding="utf-8")
    bin_dir = Path(sys.executable).parent  # the generator runs ruff from there
    run = subprocess.run([str(bin_dir / "openapi-python-client"), "generate",
                          "--path", str(spec), "--config", str(CONFIG), "--meta", "none",
                          "--output-path", str(where / PACKAGE)],
                         capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}"})
    assert run.returncode == 0, run.stdout + run.stderr
    # A warning means an operation or a model was left out or typed loosely.
    assert "Warning" not in run.stdout + run.stderr, run.stdout + run.stderr
    sys.path.insert(0, str(where))
    try:
        yield importlib.import_module(PACKAGE)
    finally:
        sys.path.remove(str(where))
        for name in [m for m in sys.modules if m.split(".")[0] == PACKAGE]:
            del sys.modules[name]


def _api(generated: ModuleType, tag: str, operation: str) -> Any:
    return importlib.import_module(f"{PACKAGE}.api.{tag}.{operation}")


def _models(generated: ModuleType) -> Any:
    return importlib.import_module(f"{PACKAGE}.models")


@pytest.fixture(scope="module")
def client(generated: ModuleType, server: Server) -> Any:
    return generated.AuthenticatedClient(base_url=server.url, token=KEY,
                                         raise_on_unexpected_status=True)


def _solved(generated: ModuleType, client: Any) -> str:
    """A small problem submitted and polled until it succeeded; its id."""
    models = _models(generated)
    submit = _api(generated, "layouts", "submit_layout")
    answer = submit.sync_detailed(client=client, body=models.Problem.from_dict(SMALL))
    assert answer.status_code == 202, answer.content
    job = answer.parsed
    assert isinstance(job, models.JobPublic)
    get_layout = _api(generated, "layouts", "get_layout")
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        status = get_layout.sync(client=client, job_id=job.id)
        assert isinstance(status, models.JobPublic)
        if status.status.value in ("succeeded", "failed", "canceled"):
            break
        time.sleep(0.2)
    assert status.status.value == "succeeded", status
    return str(job.id)


def test_a_generated_client_submits_polls_and_reads_every_result(
        generated: ModuleType, client: Any) -> None:
    models = _models(generated)
    job_id = _solved(generated, client)

    layout = _api(generated, "results", "get_layout_result").sync(client=client, job_id=job_id)
    assert isinstance(layout, models.Layout)
    assert sorted(room.id for room in layout.rooms) == ["bed", "living"]
    assert layout.report.valid is True

    svg = _api(generated, "results", "get_layout_svg").sync(client=client, job_id=job_id)
    assert isinstance(svg, str) and "<svg" in svg and "</svg>" in svg

    ifc = _api(generated, "results", "get_layout_ifc").sync(client=client, job_id=job_id,
                                                           storey_height=3.2)
    payload = ifc.payload.read()
    assert payload.startswith(b"ISO-10303-21;") and b"IFCSPACE" in payload

    stream = _api(generated, "layouts", "get_layout_events").sync(client=client,
                                                                  job_id=job_id)
    assert isinstance(stream, str)
    first = stream.split("\n\n")[0].splitlines()
    fields = dict(line.split(": ", 1) for line in first)
    assert fields["id"] == "1" and fields["event"] == "status"
    assert json.loads(fields["data"])["status"] in ("queued", "running")


def test_a_generated_client_reads_a_page_of_a_batchs_results(
        generated: ModuleType, client: Any) -> None:
    models = _models(generated)
    request = models.BatchRequest.from_dict({"problem": SMALL, "count": 2, "seed": 3})
    batch = _api(generated, "batches", "submit_batch").sync(client=client, body=request)
    assert isinstance(batch, models.BatchPublic) and batch.count == 2
    get_batch = _api(generated, "batches", "get_batch")
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        state = get_batch.sync(client=client, batch_id=batch.id)
        if state.queued + state.running == 0:
            break
        time.sleep(0.3)
    assert state.succeeded == 2, state
    page = _api(generated, "batches", "get_batch_results").sync(client=client,
                                                               batch_id=batch.id, limit=1)
    assert isinstance(page, str)
    lines = [json.loads(line) for line in page.splitlines()]
    assert [(line["index"], line["seed"]) for line in lines] == [(0, 3)]
    assert lines[0]["layout"]["rooms"]


def test_a_generated_client_gets_errors_as_problem_documents(
        generated: ModuleType, client: Any) -> None:
    models = _models(generated)
    missing = _api(generated, "layouts", "get_layout").sync_detailed(
        client=client, job_id=str(uuid.uuid4()))
    assert missing.status_code == 404
    assert isinstance(missing.parsed, models.ProblemDetails)
    assert missing.parsed.type_ == "/docs/problems/job-not-found"

    bad = {**SMALL, "rooms": [{"id": "a", "min_size": [3, 2], "max_size": [2, 2]}],
           "adjacency": []}
    refused = _api(generated, "layouts", "submit_layout").sync_detailed(
        client=client, body=models.Problem.from_dict(bad))
    assert refused.status_code == 422
    assert isinstance(refused.parsed, models.ProblemDetails)
    assert refused.parsed.type_ == "/docs/problems/invalid-problem"
    assert [e.field for e in refused.parsed.errors] == ["rooms.0.min_size.0"]


def test_without_a_key_the_generated_client_gets_a_401_problem(
        generated: ModuleType, server: Server) -> None:
    models = _models(generated)
    anonymous = generated.Client(base_url=server.url)
    answer = _api(generated, "layouts", "list_layouts").sync_detailed(client=anonymous)
    assert answer.status_code == 401
    assert isinstance(answer.parsed, models.ProblemDetails)
