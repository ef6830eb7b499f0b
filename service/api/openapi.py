"""The OpenAPI document, written for the tools that generate clients from it: short
operation ids (the routes' names in camelCase), the models the hand-validated bodies
refer to, and every error status a route can answer declared as a problem document
(RFC 9457, application/problem+json)."""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from fastapi.routing import APIRoute

from floorplan.models import Problem as LayoutProblem
from floorplan.models.jobs import BatchRequest
from floorplan.models.templates import TemplatedProblem
from floorplan.service.api.errors import PROBLEM_JSON, ProblemDetails

#: The document's title, from which generators name the package they write
#: (openapi-python-client: `floorplan_layout_api_client`); not the SDK's own name,
#: `floorplan_client`.
TITLE = "Floorplan Layout API"

#: The statuses every operation may answer, whatever its route.
_EVERYWHERE = {
    "400": "a malformed request: a Host header not allowed (FLOORPLAN_ALLOWED_HOSTS), "
           "a body that is not JSON, a cursor or Last-Event-ID this service did not give",
    "500": "an internal error (logged)",
}
#: The paths whose operations need a valid API key when keys are set (401 otherwise).
_KEYED = ("/v1/layouts", "/v1/batches", "/v1/validate")
#: The paths whose operations read or write the job store (503 when it cannot).
_STORED = ("/v1/layouts", "/v1/batches")


def operation_id(route: APIRoute) -> str:
    """A route's operation id: its function's name in camelCase (``submit_layout``:
    ``submitLayout``)."""
    if route.operation_id:
        return route.operation_id
    head, *rest = route.name.split("_")
    return head + "".join(word.capitalize() for word in rest)


def openapi(app: FastAPI) -> dict[str, Any]:
    """FastAPI's schema plus the Problem model the hand-validated bodies refer to, and
    the problem document on every error status."""
    if app.openapi_schema:
        return app.openapi_schema
    schema = get_openapi(title=app.title, version=app.version, description=app.description,
                         routes=app.routes)
    components = schema.setdefault("components", {}).setdefault("schemas", {})
    for model, name in ((LayoutProblem, "Problem"), (TemplatedProblem, "TemplatedProblem"),
                        (BatchRequest, "BatchRequest"), (ProblemDetails, "ProblemDetails")):
        model_schema = model.model_json_schema(ref_template="#/components/schemas/{model}")
        components.update(model_schema.pop("$defs", {}))
        components[name] = model_schema
    for path, item in schema["paths"].items():
        for operation in item.values():
            _declare_errors(path, operation)
    for unused in ("HTTPValidationError", "ValidationError"):
        components.pop(unused, None)
    app.openapi_schema = schema
    return schema


def _declare_errors(path: str, operation: dict[str, Any]) -> None:
    """Every error status `operation` (at `path`) can answer, each a problem document
    unless the route declares its own body (/readyz's 503)."""
    responses: dict[str, Any] = operation.setdefault("responses", {})
    wanted = dict(_EVERYWHERE)
    if path.startswith(_KEYED):
        wanted["401"] = "API keys are set and none valid was given"
    else:  # a key is looked at, never required (/readyz's figures)
        operation.get("security", []).append({})
    if path.startswith(_STORED):
        wanted["503"] = "the job store cannot take this request now; see Retry-After"
    if operation.get("parameters") or operation.get("requestBody"):
        wanted["422"] = "an invalid parameter or body; `errors` names the fields"
    for code, description in wanted.items():
        responses.setdefault(code, {"description": description})
    problem = {PROBLEM_JSON: {"schema": {"$ref": "#/components/schemas/ProblemDetails"}}}
    for code, response in responses.items():
        content = response.get("content", {})
        own = any("$ref" in media.get("schema", {}) for media in content.values())
        if code[0] in "45" and not (own and code != "422"):
            response["content"] = problem
    responses.setdefault("default", {"description": "an error", "content": problem})
