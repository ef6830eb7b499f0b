"""The documentation pages: /docs (Swagger UI) and /redoc rendered in real headless
Chromium with every request to another host refused, as on a machine without
internet; and a page for every problem type URI the service answers with."""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient

from floorplan.service.api.app import create_app
from floorplan.service.api.problem_types import PROBLEM_TYPES
from floorplan.service.settings import Settings
from tests.paths import ROOT
from tests.servers import Server

#: Milliseconds for a page to render on a busy machine.
RENDER_MS = 60_000


@pytest.fixture(scope="module")
def app_client(tmp_path_factory: pytest.TempPathFactory) -> TestClient:
    """The app without its backend started: the pages need none."""
    return TestClient(create_app(Settings(data_dir=tmp_path_factory.mktemp("data"))),
                      base_url="http://localhost")


def test_every_problem_type_the_code_answers_with_has_a_page(app_client: TestClient) -> None:
    source = "\n".join(p.read_text(encoding="utf-8")
                       for p in (ROOT / "service").rglob("*.py"))
    used = set(re.findall(r'kind="([a-z-]+)"', source))
    used |= set(re.findall(r'too_many\([^)]*"(too-many-[a-z-]+)"\)', source, re.DOTALL))
    used |= set(re.findall(r'WorkPool\([^)]*"([a-z-]+-unavailable)"\)', source, re.DOTALL))
    assert {"job-not-found", "too-many-streams", "untrusted-host",
            "explain-unavailable", "export-unavailable"} <= used
    assert used <= set(PROBLEM_TYPES), used - set(PROBLEM_TYPES)
    for kind, problem in PROBLEM_TYPES.items():
        page = app_client.get(f"/docs/problems/{kind}")
        assert page.status_code == 200, kind
        assert page.headers["content-type"].startswith("text/html")
        assert f"{problem.status} {problem.title}" in page.text
    index = app_client.get("/docs/problems")
    assert all(f'href="/docs/problems/{kind}"' in index.text for kind in PROBLEM_TYPES)
    missing = app_client.get("/docs/problems/no-such-thing")
    assert missing.status_code == 404
    assert missing.json()["type"] == "/docs/problems/problem-type-not-found"


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("docs"), WORKERS="1").start()
    yield s
    s.stop()


@pytest.fixture
def offline(browser: Any, server: Server) -> Iterator[tuple[Any, list[str]]]:
    """A tab whose requests to any host but the server's are refused; and the list of
    those it tried."""
    context = browser.new_context()
    tried: list[str] = []
    here = urlsplit(server.url).netloc

    def only_here(route: Any) -> None:
        url = route.request.url
        if urlsplit(url).scheme in ("http", "https") and urlsplit(url).netloc != here:
            tried.append(url)
            route.abort("internetdisconnected")
        else:
            route.continue_()

    context.route("**/*", only_here)
    yield context.new_page(), tried
    context.close()


@pytest.mark.slow
def test_swagger_ui_renders_with_no_other_host_reachable(
        offline: tuple[Any, list[str]], server: Server) -> None:
    from playwright.sync_api import expect

    tab, tried = offline
    errors: list[str] = []
    tab.on("pageerror", lambda err: errors.append(str(err)))
    tab.goto(f"{server.url}/docs")
    expect(tab.locator(".swagger-ui .info .title")).to_contain_text(
        "Floorplan Layout API", timeout=RENDER_MS)
    # Every operation listed, by its path: the document was read and drawn.
    operations = tab.locator(".opblock-summary-path")
    expect(operations.first).to_be_visible(timeout=RENDER_MS)
    paths = set(operations.all_inner_texts())
    assert {"/v1/layouts", "/v1/layouts/{job_id}/result/svg", "/readyz"} <= {
        p.replace("\u200b", "") for p in paths}
    assert not tried and not errors, (tried, errors)


@pytest.mark.slow
def test_redoc_renders_with_no_other_host_reachable(
        offline: tuple[Any, list[str]], server: Server) -> None:
    from playwright.sync_api import expect

    tab, tried = offline
    tab.goto(f"{server.url}/redoc")
    expect(tab.locator("h1").first).to_contain_text("Floorplan Layout API", timeout=RENDER_MS)
    # Every operation drawn, by its summary.
    expect(tab.get_by_text("Get Layout Svg").first).to_be_attached(timeout=RENDER_MS)
    assert not tried, tried


def test_the_docs_pages_load_their_assets_from_this_service(app_client: TestClient) -> None:
    for page in ("/docs", "/redoc"):
        html = app_client.get(page).text
        assert not re.findall(r"(?:src|href)=[\"']?(?:https?:)?//", html), page
        for asset in re.findall(r"/docs/assets/[\w.-]+", html):
            assert app_client.get(asset).status_code == 200, asset
