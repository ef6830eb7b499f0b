"""The application: its routers, its error handlers, the web page, and the job backend
the settings ask for, started and stopped with it; and its OpenAPI schema."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import anyio
from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi

from floorplan.models import Problem as LayoutProblem
from floorplan.models.jobs import BatchRequest
from floorplan.models.templates import TemplatedProblem
from floorplan.service.api import web
from floorplan.service.api.errors import ProblemDetails, TrustedHosts, install
from floorplan.service.api.limits import Limits
from floorplan.service.api.routes import batches, health, layouts, validate
from floorplan.service.jobs.factory import make_backend
from floorplan.service.settings import Settings, get_settings


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        backend = await asyncio.to_thread(make_backend, settings)
        app.state.settings, app.state.backend = settings, backend
        # Bodies are parsed and validated in worker threads, this many at once.
        app.state.parse_limiter = anyio.CapacityLimiter(settings.parse_threads)
        app.state.limits = Limits(settings)
        backend.start()
        try:
            yield
        finally:
            app.state.limits.close()
            await backend.aclose()
            await asyncio.to_thread(backend.stop)

    app = FastAPI(
        title="floorplan", version="0.1.0", lifespan=lifespan,
        description="Interior layouts as asynchronous jobs: post a problem, follow the job, "
        "fetch the layout. Errors are RFC 9457 problem documents.",
    )
    install(app)
    app.add_middleware(TrustedHosts, allowed_hosts=settings.trusted_hosts)
    app.include_router(layouts.router)
    app.include_router(batches.router)
    app.include_router(validate.router)
    app.include_router(health.router)
    web.install(app)  # the page at /, its static files, the examples
    app.openapi = lambda: _openapi(app)  # type: ignore[method-assign]
    return app


def _openapi(app: FastAPI) -> dict[str, Any]:
    """FastAPI's schema plus the Problem model the hand-validated bodies refer to."""
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
    # Errors are problem documents (RFC 9457), FastAPI's own 422 included.
    problem_doc = {"application/problem+json": {
        "schema": {"$ref": "#/components/schemas/ProblemDetails"}}}
    for operation in (op for path in schema["paths"].values() for op in path.values()):
        responses = operation.setdefault("responses", {})
        for code, response in responses.items():
            if code[0] in "45":
                response["content"] = problem_doc
        responses.setdefault("default", {"description": "an error", "content": problem_doc})
    for unused in ("HTTPValidationError", "ValidationError"):
        components.pop(unused, None)
    app.openapi_schema = schema
    return schema
