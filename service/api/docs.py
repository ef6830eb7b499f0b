"""The API's documentation pages, served whole from this machine: Swagger UI at /docs
and ReDoc at /redoc from the assets the `fastapi-offline` package ships (FastAPI's own
pages load them from a public CDN, and are blank without internet), and a page for
every problem type URI (/docs/problems/KIND)."""

from __future__ import annotations

import re
from html import escape
from pathlib import Path
from typing import Annotated

import fastapi_offline
from fastapi import APIRouter, FastAPI
from fastapi import Path as PathParam
from fastapi.openapi.docs import (
    get_redoc_html,
    get_swagger_ui_html,
    get_swagger_ui_oauth2_redirect_html,
)
from fastapi.responses import HTMLResponse
from fastapi.staticfiles import StaticFiles

from floorplan.service.api.errors import TYPE_BASE, ApiError
from floorplan.service.api.problem_types import PROBLEM_TYPES

#: Swagger UI's and ReDoc's scripts, styles and icon, as the package ships them.
ASSETS_DIR = Path(fastapi_offline.__file__).with_name("static")
ASSETS_URL = "/docs/assets"
#: Swagger UI and ReDoc load nothing from elsewhere (ReDoc would fetch its makers' logo
#: from their CDN): their inline start-up scripts and styles, ReDoc's workers.
DOCS_PAGE_SECURITY = {
    "Content-Security-Policy": "default-src 'self'; script-src 'self' 'unsafe-inline'; "
    "style-src 'self' 'unsafe-inline'; img-src 'self' data:; font-src 'self' data:; "
    "worker-src 'self' blob:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
}
#: Problem pages: text, no script, nothing from elsewhere.
PROBLEM_PAGE_SECURITY = {
    "Content-Security-Policy": "default-src 'none'; style-src 'unsafe-inline'; "
    "base-uri 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
}
_STYLE = "body{font-family:sans-serif;max-width:44em;margin:2em auto;line-height:1.5}"


def install(app: FastAPI) -> None:
    """Add /docs, /redoc, their assets and the problem pages (the app is made with
    ``docs_url=None, redoc_url=None``)."""
    openapi_url = app.openapi_url or "/openapi.json"
    redirect_url = app.swagger_ui_oauth2_redirect_url or "/docs/oauth2-redirect"
    pages = APIRouter(include_in_schema=False)

    @pages.get("/docs")
    def swagger_ui() -> HTMLResponse:
        return _secured(get_swagger_ui_html(
            openapi_url=openapi_url, title=f"{app.title} - Swagger UI",
            oauth2_redirect_url=redirect_url,
            swagger_js_url=f"{ASSETS_URL}/swagger-ui-bundle.js",
            swagger_css_url=f"{ASSETS_URL}/swagger-ui.css",
            swagger_favicon_url=f"{ASSETS_URL}/favicon.png",
            # No validator badge: it would ask validator.swagger.io about the schema.
            swagger_ui_parameters={"validatorUrl": None}))

    @pages.get(redirect_url)
    def swagger_ui_redirect() -> HTMLResponse:
        return get_swagger_ui_oauth2_redirect_html()

    @pages.get("/redoc")
    def redoc() -> HTMLResponse:
        return _secured(get_redoc_html(
            openapi_url=openapi_url, title=f"{app.title} - ReDoc",
            redoc_js_url=f"{ASSETS_URL}/redoc.standalone.js",
            redoc_favicon_url=f"{ASSETS_URL}/favicon.png", with_google_fonts=False))

    @pages.get(TYPE_BASE.rstrip("/"))
    def problem_index() -> HTMLResponse:
        items = "".join(f'<li><a href="{TYPE_BASE}{kind}">{kind}</a>: {t.status} '
                        f"{escape(t.title)}</li>" for kind, t in PROBLEM_TYPES.items())
        return _page("Problem types", "<p>The <code>type</code> of every problem "
                     "document (RFC 9457) this service answers with.</p>"
                     f"<ul>{items}</ul>")

    @pages.get(TYPE_BASE + "{kind}")
    def problem_page(kind: Annotated[str, PathParam(max_length=100)]) -> HTMLResponse:
        found = PROBLEM_TYPES.get(kind)
        if found is None:
            raise ApiError(404, f"there is no problem type {kind!r}",
                           kind="problem-type-not-found")
        return _page(f"{found.status} {found.title}",
                     f"<p>{_text(found.explanation)}</p><p><code>type</code>: "
                     f"<code>{TYPE_BASE}{kind}</code></p>"
                     f'<p><a href="{TYPE_BASE.rstrip("/")}">Every problem type</a></p>')

    app.include_router(pages)
    app.mount(ASSETS_URL, StaticFiles(directory=ASSETS_DIR), name="docs-assets")


def _secured(page: HTMLResponse) -> HTMLResponse:
    page.headers.update(DOCS_PAGE_SECURITY)
    return page


def _text(text: str) -> str:
    """`text` as HTML, its `quoted` parts as code."""
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", escape(text))


def _page(title: str, body: str) -> HTMLResponse:
    html = (f'<!doctype html><html lang="en"><head><meta charset="utf-8"><title>'
            f"{escape(title)}</title><style>{_STYLE}</style></head><body><h1>"
            f"{escape(title)}</h1>{body}</body></html>")
    return HTMLResponse(html, headers=PROBLEM_PAGE_SECURITY)
