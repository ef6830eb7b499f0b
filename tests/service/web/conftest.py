"""The web page's browser tests share these: Debian's Chromium (/usr/bin/chromium,
driven by Playwright) against a real `floorplan serve` process on loopback, a fresh
context per test that fails it on any script error, and helpers to pick, download and
take screenshots (build/screenshots/).

Without the browser the tests skip, saying why; under CI (the CI variable set) they
fail instead, so that a missing install cannot pass for a green run.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.paths import ROOT
from tests.servers import Server

SCREENSHOTS = ROOT / "build" / "screenshots"
VIEWPORT = {"width": 1280, "height": 860}
#: Milliseconds to wait for a job to end; apartment-5 takes about a second.
JOB_TIMEOUT_MS = 30_000


@pytest.fixture(scope="package")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """One server for the page's test modules (its start is seconds of the suite)."""
    s = Server(tmp_path_factory.mktemp("web"), WORKERS="1").start()
    yield s
    s.stop()


@pytest.fixture
def page(browser: Any) -> Iterator[Any]:
    """A fresh browser context (no stored key or job); fails the test on any script
    error or Content-Security-Policy violation the page logs."""
    context = browser.new_context(viewport=VIEWPORT, accept_downloads=True)
    tab = context.new_page()
    errors: list[str] = []
    tab.on("pageerror", lambda err: errors.append(f"uncaught: {err}"))
    # Answers of 4xx are part of the tests; the browser logs each as a failed load.
    tab.on("console", lambda msg: errors.append(msg.text) if msg.type == "error"
           and "Failed to load resource" not in msg.text else None)
    yield tab
    context.close()
    assert not errors, errors


def expect(locator: Any) -> Any:
    from playwright.sync_api import expect as playwright_expect

    return playwright_expect(locator)


def screenshot(tab: Any, name: str) -> None:
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    tab.screenshot(path=str(SCREENSHOTS / name), full_page=True)


#: The rows of the editor's programme table, one per room.
ROWS = "[data-testid=room-row]"


def open_six_room_flat(tab: Any, url: str) -> None:
    """The page at `url`, the six-room flat template in the editor."""
    tab.goto(url)
    tab.select_option("#example", "template:flat-6")
    expect(tab.locator(ROWS)).to_have_count(6)


def pick_example(tab: Any, name: str, *, time_limit: str) -> None:
    expect(tab.locator(f"#example option[value='{name}']")).to_be_attached()
    tab.select_option("#example", name)
    expect(tab.locator("#problem")).to_have_value(re.compile(f'"name": "{name}"'))
    tab.fill("#time-limit", time_limit)


def download(tab: Any, link: str) -> tuple[str, str]:
    """Clicks a download link; returns the file's suggested name and its text."""
    with tab.expect_download() as started:
        tab.click(link)
    saved = started.value
    return saved.suggested_filename, Path(saved.path()).read_text(encoding="utf-8")
