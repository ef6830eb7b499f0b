"""The one reader of request bodies (POST /v1/layouts, /v1/validate, /v1/batches): the
caller's key checked from the headers first, then the media type and the declared
size, the body read only up to `FLOORPLAN_MAX_BODY_BYTES`, and parsed and validated in
a worker thread rather than by FastAPI on the event loop, so that every error is a
problem document; and the bodies' description in the OpenAPI schema, with examples."""

from __future__ import annotations

import json
from collections.abc import Callable
from functools import partial
from typing import Annotated, Any, TypeVar

import anyio.to_thread
from anyio import CapacityLimiter
from fastapi import Depends, Request
from pydantic import ValidationError

from floorplan.models import Problem as LayoutProblem
from floorplan.models.jobs import BatchRequest
from floorplan.service.api.deps import OwnerDep, SettingsDep
from floorplan.service.api.errors import ApiError, FieldError, field_errors
from floorplan.service.settings import Settings

T = TypeVar("T")
#: Invalid fields listed at most in one answer: the count says how many there are. Not
#: 20,000 of them, a 2.4 MB answer built and sent on the event loop.
MAX_FIELD_ERRORS = 100

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


async def read_body(request: Request, settings: Settings) -> bytes:
    """The request's body, read only when it is JSON and within the size limit: a body
    not sent as `application/json` (the types a web page may post to another site
    without asking, text/plain and forms) is a 415, a `Content-Length` above
    `FLOORPLAN_MAX_BODY_BYTES` a 413, both before a byte is read; a body streamed
    without a length is read up to the limit and no further. The caller's key is the
    route's to check before this (every body route depends on `OwnerDep` first)."""
    media_type = request.headers.get("content-type", "").partition(";")[0].strip().lower()
    if media_type != "application/json":
        raise ApiError(415, f"the body must be sent as application/json, not "
                       f"{media_type[:100] or 'without a Content-Type'}",
                       kind="unsupported-media-type", headers={"Accept-Post": "application/json"})
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > settings.max_body_bytes:
        raise too_large(settings)
    body = bytearray()
    async for chunk in request.stream():
        body += chunk
        if len(body) > settings.max_body_bytes:
            raise too_large(settings)
    return bytes(body)


def too_large(settings: Settings) -> ApiError:
    # Connection: close, since the rest of the body is not read: the client learns at
    # once that the connection ends with this answer.
    return ApiError(413, f"the body exceeds {settings.max_body_bytes} bytes "
                    "(FLOORPLAN_MAX_BODY_BYTES)", kind="body-too-large",
                    headers={"Connection": "close"})


async def problem_body(
    request: Request, settings: SettingsDep, owner: OwnerDep,
) -> tuple[LayoutProblem, bytes]:
    """The request body as a validated problem, within the size limits, after the key
    (`owner`, resolved first: an unauthenticated body is never read). Parsing and
    validating it, which takes time in proportion to its size, runs in a worker thread,
    at most `FLOORPLAN_PARSE_THREADS` at once, so that a large body does not hold up
    /healthz or anyone else's request."""
    raw = await read_body(request, settings)
    problem = await run_off_loop(request, partial(parse_problem, raw, settings))
    return problem, raw


async def batch_body(request: Request, settings: SettingsDep, owner: OwnerDep) -> BatchRequest:
    """POST /v1/batches' body, read as `problem_body` reads a problem (key first, size
    limit, off the event loop): the request's fields, then its brief checked as any
    job's body (its sizes, the model, the extent, the time-limit ceiling), its errors
    named under `problem`."""
    raw = await read_body(request, settings)
    return await run_off_loop(request, partial(parse_batch, raw, settings))


def parse_batch(raw: bytes, settings: Settings) -> BatchRequest:
    data = parse_json(raw)
    try:
        body = BatchRequest.model_validate(data)
    except ValidationError as err:
        raise invalid(err, kind="invalid-request") from err
    try:
        check_problem(body.problem, settings)
    except ApiError as err:
        if err.errors:
            err.errors = [error.model_copy(update={
                "loc": ["problem", *error.loc], "field": f"problem.{error.field}"})
                for error in err.errors]
        raise
    return body


async def run_off_loop(request: Request, work: Callable[[], T]) -> T:
    """`work` in a worker thread, within the app's limit of threads for such work."""
    limiter: CapacityLimiter = request.app.state.parse_limiter
    return await anyio.to_thread.run_sync(work, limiter=limiter)


def parse_json(raw: bytes) -> Any:
    try:
        return json.loads(raw)
    # ValueError: not JSON, not UTF-8, or an integer beyond Python's 4,300 digits;
    # RecursionError: arrays or objects nested deeper than the parser goes.
    except (ValueError, RecursionError) as err:
        reason = "nested too deeply" if isinstance(err, RecursionError) else str(err)[:200]
        raise ApiError(400, f"the body is not JSON: {reason}", kind="malformed-json") from err


def invalid(err: ValidationError, *, kind: str) -> ApiError:
    """A 422 listing at most `MAX_FIELD_ERRORS` of `err`'s fields."""
    count = err.error_count()
    errors = field_errors(err.errors()[:MAX_FIELD_ERRORS])
    listed = f", the first {len(errors)} listed" if count > len(errors) else ""
    return ApiError(422, f"{count} invalid field(s){listed}", kind=kind, errors=errors)


def parse_problem(raw: bytes, settings: Settings) -> LayoutProblem:
    """`raw` as a validated problem (`check_problem`)."""
    return check_problem(parse_json(raw), settings)


def check_problem(data: Any, settings: Settings) -> LayoutProblem:
    """Parsed JSON as a validated problem: its sizes first (cheap, before the validation
    that grows with them), then the model, then the service's own limits."""
    oversized = size_errors(data, settings)
    if oversized:
        raise ApiError(413, "the problem is larger than this service takes: "
                       + "; ".join(f"{e.field}: {e.message}" for e in oversized),
                       kind="problem-too-large", errors=oversized)
    try:
        problem = LayoutProblem.model_validate(data, context={"max_rooms": settings.max_rooms})
    except ValidationError as err:
        raise invalid(err, kind="invalid-problem") from err
    too_wide = extent_errors(problem, settings.max_extent)
    if too_wide:
        raise ApiError(422, "; ".join(f"{e.field}: {e.message}" for e in too_wide),
                       kind="invalid-problem", errors=too_wide)
    limit = problem.options.time_limit
    if limit is not None and limit > settings.max_time_limit:
        raise ApiError(422, f"time_limit may be at most {settings.max_time_limit} s",
                       kind="invalid-problem", errors=[FieldError(
                           field="options.time_limit", loc=["options", "time_limit"],
                           message=f"at most {settings.max_time_limit}", type="less_than_equal",
                       )])
    return problem


def size_errors(data: Any, settings: Settings) -> list[FieldError]:
    """The lists of `data` (parsed JSON, not yet validated) longer than the settings
    allow: outline vertices, obstacles (top-level and each floor's) and regions. Their
    lengths alone: what is in them is the model's to check."""
    if not isinstance(data, dict):
        return []
    limits = {"boundary": (settings.max_vertices, "FLOORPLAN_MAX_VERTICES"),
              "obstacles": (settings.max_obstacles, "FLOORPLAN_MAX_OBSTACLES"),
              "regions": (settings.max_regions, "FLOORPLAN_MAX_REGIONS")}
    places: list[tuple[list[str | int], dict[str, Any]]] = [([], data)]
    floors = data.get("floors")
    if isinstance(floors, list):
        places += [(["floors", i], floor) for i, floor in enumerate(floors)
                   if isinstance(floor, dict)]
    errors = []
    for prefix, place in places:
        for name, (limit, variable) in limits.items():
            if name == "regions" and prefix:
                continue  # regions are the problem's, not a floor's
            items = place.get(name)
            if isinstance(items, list) and len(items) > limit:
                loc = [*prefix, name]
                errors.append(FieldError(
                    field=".".join(str(part) for part in loc), loc=loc, type="too_many_items",
                    message=f"{len(items)} items exceed this service's limit of {limit} "
                    f"({variable})"))
    return errors


def extent_errors(problem: LayoutProblem, max_extent: float) -> list[FieldError]:
    """The outlines (the problem's, each floor's) wider or deeper than `max_extent`
    metres: a building, not a country. A 276-byte problem of a 200 km square made
    266,663 windows, a 20 MB layout and an 82 MB SVG plan."""
    outlines: list[tuple[list[str | int], Any]] = [(["boundary"], problem.boundary)]
    outlines += [(["floors", i, "boundary"], floor.boundary)
                 for i, floor in enumerate(problem.floors or []) if floor.boundary]
    errors = []
    for loc, outline in outlines:
        xs, ys = [p[0] for p in outline], [p[1] for p in outline]
        extent = max(max(xs) - min(xs), max(ys) - min(ys))
        if extent > max_extent:
            errors.append(FieldError(
                field=".".join(str(part) for part in loc), loc=loc, type="too_large",
                message=f"spans {extent:g} m, more than this service's {max_extent:g} m "
                "(FLOORPLAN_MAX_EXTENT)"))
    return errors


ProblemBody = Annotated[tuple[LayoutProblem, bytes], Depends(problem_body)]
BatchBody = Annotated[BatchRequest, Depends(batch_body)]
BATCH_BODY_DOC: dict[str, Any] = {
    "requestBody": {"required": True, "content": {"application/json": {
        "schema": {"$ref": "#/components/schemas/BatchRequest"}}}},
}
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
