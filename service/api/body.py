"""The problem a request carries (POST /v1/layouts, POST /v1/validate): read within the
size limit and validated here rather than by FastAPI, so that every error is a problem
document; and its description in the OpenAPI schema, with examples."""

from __future__ import annotations

import json
from typing import Annotated, Any

from fastapi import Depends, Request
from pydantic import ValidationError

from models import Problem as LayoutProblem
from service.api.deps import SettingsDep
from service.api.errors import ApiError, FieldError, field_errors

EXAMPLE_PROBLEM: dict[str, Any] = {
    "name": "studio",
    "boundary": [[0, 0], [8, 0], [8, 6], [0, 6]],
    "entrance": [4, 0],
    "rooms": [
        {"id": "living", "type": "living", "min_size": [3, 3], "max_size": [6, 5],
         "target_size": [5, 4], "positions": [[4, 0.5]]},
        {"id": "bed", "type": "bedroom", "min_size": [2.5, 2.5], "max_size": [4, 4],
         "target_size": [3, 3], "boundary": ["north"]},
        {"id": "bath", "type": "bathroom", "min_size": [1.5, 1.5], "max_size": [3, 3],
         "target_size": [2, 2]},
    ],
    "adjacency": [{"a": "living", "b": "bed"}, {"a": "bed", "b": "bath"}],
    "options": {"time_limit": 5, "seed": 0},
}
#: The same flat from its room types alone: the residential template fills in the rest.
EXAMPLE_TEMPLATED: dict[str, Any] = {
    "name": "studio",
    "boundary": [[0, 0], [8, 0], [8, 6], [0, 6]],
    "entrance": [4, 0],
    "template": "residential",
    "rooms": ["living", "bedroom", "bathroom"],
    "options": {"time_limit": 5, "seed": 0},
}


async def problem_body(request: Request, settings: SettingsDep) -> tuple[LayoutProblem, bytes]:
    """The request body as a validated problem, within the size limit."""
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > settings.max_body_bytes:
        raise ApiError(413, f"the body exceeds {settings.max_body_bytes} bytes",
                       kind="body-too-large")
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > settings.max_body_bytes:
            raise ApiError(413, f"the body exceeds {settings.max_body_bytes} bytes",
                           kind="body-too-large")
    try:
        data = json.loads(body)
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ApiError(400, f"the body is not JSON: {err}", kind="malformed-json") from err
    try:
        problem = LayoutProblem.model_validate(data, context={"max_rooms": settings.max_rooms})
    except ValidationError as err:
        errors = field_errors(err.errors())
        raise ApiError(422, f"{len(errors)} invalid field(s)", kind="invalid-problem",
                       errors=errors) from err
    limit = problem.options.time_limit
    if limit is not None and limit > settings.max_time_limit:
        raise ApiError(422, f"time_limit may be at most {settings.max_time_limit} s",
                       kind="invalid-problem", errors=[FieldError(
                           field="options.time_limit", loc=["options", "time_limit"],
                           message=f"at most {settings.max_time_limit}", type="less_than_equal",
                       )])
    return problem, bytes(body)


ProblemBody = Annotated[tuple[LayoutProblem, bytes], Depends(problem_body)]
PROBLEM_BODY_DOC: dict[str, Any] = {
    "requestBody": {
        "required": True,
        "content": {"application/json": {
            # A plain problem, or one a template fills in from its room types.
            "schema": {"anyOf": [{"$ref": "#/components/schemas/Problem"},
                                 {"$ref": "#/components/schemas/TemplatedProblem"}]},
            "examples": {
                "plain": {"summary": "every constraint stated", "value": EXAMPLE_PROBLEM},
                "templated": {"summary": "room types only (residential template)",
                              "value": EXAMPLE_TEMPLATED},
            },
        }},
    }
}
