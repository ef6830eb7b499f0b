"""The application: its routers, its error handlers, the web page, and the job backend
the settings ask for, started and stopped with it; its OpenAPI schema is openapi.py."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
from fastapi import FastAPI

from floorplan.service.api import docs, web
from floorplan.service.api.errors import TrustedHosts, install
from floorplan.service.api.limits import Limits
from floorplan.service.api.openapi import TITLE, openapi, operation_id
from floorplan.service.api.routes import batches, health, layouts, results, validate
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
        title=TITLE, version="0.1.0", lifespan=lifespan,
        generate_unique_id_function=operation_id,
        docs_url=None, redoc_url=None,  # docs.py serves them, offline
        description="Interior layouts as asynchronous jobs: post a problem, follow the job, "
        "fetch the layout. Errors are RFC 9457 problem documents.",
    )
    install(app)
    app.add_middleware(TrustedHosts, allowed_hosts=settings.trusted_hosts)
    app.include_router(layouts.router)
    app.include_router(results.router)
    app.include_router(batches.router)
    app.include_router(validate.router)
    app.include_router(health.router)
    web.install(app)  # the page at /, its static files, the examples
    docs.install(app)  # /docs, /redoc and the problem pages
    app.openapi = lambda: openapi(app)  # type: ignore[method-assign]
    return app
