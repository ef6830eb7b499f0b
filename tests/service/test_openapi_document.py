"""The OpenAPI document as client generators read it (no server: the app's own
schema): one media type per success, an operation per export format, short operation
ids, every error a problem document, the keys as security schemes."""

from __future__ import annotations

import re
from typing import Any

import pytest

from floorplan.models.formats import MEDIA_TYPES, RENDERED_FORMAT_NAMES
from floorplan.service.api.app import create_app
from floorplan.service.settings import Settings

PROBLEM = {"application/problem+json": {"schema": {"$ref": "#/components/schemas/ProblemDetails"}}}


@pytest.fixture(scope="module")
def schema(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    settings = Settings(data_dir=tmp_path_factory.mktemp("data"))
    return create_app(settings).openapi()


def operations(schema: dict[str, Any]) -> list[tuple[str, str, dict[str, Any]]]:
    return [(path, method, op) for path, item in schema["paths"].items()
            for method, op in item.items()]


def test_every_rendered_format_has_its_own_operation(schema: dict[str, Any]) -> None:
    for name in RENDERED_FORMAT_NAMES:
        op = schema["paths"][f"/v1/layouts/{{job_id}}/result/{name}"]["get"]
        assert op["operationId"] == f"getLayout{name.capitalize()}"
        assert list(op["responses"]["200"]["content"]) == [MEDIA_TYPES[name]]


def test_each_success_has_one_media_type_and_ids_are_short(schema: dict[str, Any]) -> None:
    ids = []
    for path, method, op in operations(schema):
        ids.append(op["operationId"])
        assert re.fullmatch(r"[a-z][a-zA-Z]{2,24}", op["operationId"]), (path, method)
        for code, response in op["responses"].items():
            if code.startswith("2"):
                assert len(response.get("content", {})) <= 1, (path, method, code)
    assert len(set(ids)) == len(ids)
    assert {"submitLayout", "getLayout", "getLayoutResult", "getLayoutEvents",
            "getBatchResults", "getBatchResultsZip"} <= set(ids)
    events = schema["paths"]["/v1/layouts/{job_id}/events"]["get"]["responses"]["200"]
    assert list(events["content"]) == ["text/event-stream"] and events["description"]
    page = schema["paths"]["/v1/batches/{batch_id}/results"]["get"]["responses"]["200"]
    assert list(page["content"]) == ["application/x-ndjson"] and page["description"]


def test_errors_are_problem_documents_and_keys_are_security_schemes(
        schema: dict[str, Any]) -> None:
    schemes = schema["components"]["securitySchemes"]
    assert schemes["bearerAuth"] == {**schemes["bearerAuth"], "type": "http",
                                     "scheme": "bearer"}
    assert schemes["apiKeyAuth"]["in"] == "header"
    assert schemes["apiKeyAuth"]["name"] == "X-API-Key"
    for path, method, op in operations(schema):
        headers = {p["name"].lower() for p in op.get("parameters", []) if p["in"] == "header"}
        assert not headers & {"authorization", "x-api-key"}, (path, method)
        codes = set(op["responses"])
        assert {"400", "500", "default"} <= codes, (path, method)
        if path.startswith(("/v1/layouts", "/v1/batches", "/v1/validate")):
            assert "401" in codes and op["security"], (path, method)
        if "{job_id}" in path or "{batch_id}" in path:
            assert {"404", "503"} <= codes, (path, method)
        for code, response in op["responses"].items():
            if code[0] in "45" and path != "/readyz":
                assert response["content"] == PROBLEM, (path, method, code)
    ready = schema["paths"]["/readyz"]["get"]["responses"]["503"]["content"]
    assert ready["application/json"]["schema"]["$ref"].endswith("/Readiness")
    # Generators name their package after the title: not the SDK's floorplan_client.
    assert re.sub(r"\W+", "_", schema["info"]["title"].lower()) != "floorplan"
