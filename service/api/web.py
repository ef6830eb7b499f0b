"""The web page at `/` and the example problems it offers.

The page is static HTML, CSS and JavaScript shipped in `service/api/static/`; it talks
to the same public API as every other client. The examples are the repository's
`examples/*.json` problems, shipped as package data through the `service/api/examples`
link so that a non-editable install serves them too. Nothing here draws or solves: the
browser draws the polygons the API returns.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, FastAPI
from fastapi import Path as PathParam
from fastapi.responses import FileResponse, HTMLResponse, Response
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, Field

from floorplan.models import Problem as LayoutProblem
from floorplan.service.api.errors import ApiError

STATIC_DIR = Path(__file__).with_name("static")
EXAMPLES_DIR = Path(__file__).with_name("examples")
#: Layout files sit beside the problems in examples/; they are results, not problems.
LAYOUT_SUFFIX = ".layout.json"
EXAMPLE_NAME = r"^[a-z0-9][a-z0-9-]{0,99}$"

#: The page loads nothing from elsewhere and runs no inline script: user strings (room
#: ids, error messages) can never become code.
PAGE_SECURITY = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' data: blob:; "
    "object-src 'none'; base-uri 'none'; frame-ancestors 'none'; form-action 'self'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}


class ExampleSummary(BaseModel):
    """One example problem, as listed."""

    name: str = Field(description="the name to fetch it by, e.g. apartment-5")
    title: str = Field(description="the problem's own `name`")
    rooms: int = Field(description="number of rooms")
    obstacles: int = Field(description="number of obstacles")
    href: str = Field(description="where the problem itself is")


class ExampleList(BaseModel):
    data: list[ExampleSummary]


@dataclass(frozen=True)
class _Example:
    summary: ExampleSummary
    text: str


@cache
def _examples() -> dict[str, _Example]:
    """The shipped examples by name, read and validated once per process."""
    found: dict[str, _Example] = {}
    if not EXAMPLES_DIR.is_dir():
        return found
    for path in sorted(EXAMPLES_DIR.glob("*.json")):
        if path.name.endswith(LAYOUT_SUFFIX) or not re.match(EXAMPLE_NAME, path.stem):
            continue
        text = path.read_text(encoding="utf-8")
        problem = LayoutProblem.model_validate_json(text)
        found[path.stem] = _Example(ExampleSummary(
            name=path.stem, title=problem.name, rooms=problem.room_count,
            obstacles=len(problem.obstacles), href=f"/v1/examples/{path.stem}",
        ), text)
    return found


examples = APIRouter(prefix="/v1/examples", tags=["examples"])


@examples.get("", response_model=ExampleList)
def list_examples() -> ExampleList:
    """The example problems this service ships, smallest first."""
    ordered = sorted(_examples().values(), key=lambda e: (e.summary.rooms, e.summary.name))
    return ExampleList(data=[e.summary for e in ordered])


@examples.get(
    "/{name}",
    responses={200: {"content": {"application/json": {
                   "schema": {"anyOf": [{"$ref": "#/components/schemas/Problem"},
                                        {"$ref": "#/components/schemas/TemplatedProblem"}]}}}},
               404: {"description": "no example of that name"}},
)
def get_example(
    name: Annotated[str, PathParam(pattern=EXAMPLE_NAME, examples=["apartment-5"])],
) -> Response:
    """One example problem, as written in its file (a templated one unexpanded): post
    it to /v1/layouts as it is."""
    example = _examples().get(name)
    if example is None:
        raise ApiError(404, f"there is no example named {name!r}", kind="example-not-found")
    return Response(example.text, media_type="application/json")


pages = APIRouter(tags=["web"])


@pages.get("/", response_class=HTMLResponse)
def web_page() -> FileResponse:
    """The web page: submit a problem, watch its layout being solved, download it."""
    return FileResponse(STATIC_DIR / "index.html", media_type="text/html",
                        headers=PAGE_SECURITY)


def install(app: FastAPI) -> None:
    """Add the page, its files under /static and the example endpoints."""
    app.include_router(pages)
    app.include_router(examples)
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

