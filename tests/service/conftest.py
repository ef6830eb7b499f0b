"""Fixtures shared by the service's tests."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.browser import headless_chromium


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """Headless Chromium for the browser tests (the web page, the docs pages)."""
    with headless_chromium() as chromium:
        yield chromium


#: Characters kept from the end of each process log a failed test attaches.
LOG_TAIL = 4000


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Iterator[None]:
    """A failed test's servers and workers log into its tmp_path: their tails go into the
    report, so that a failure seen once (on CI, under load) can be read afterwards."""
    outcome = yield
    report = outcome.get_result()
    tmp_path = getattr(item, "funcargs", {}).get("tmp_path")
    if report.when != "call" or not report.failed or tmp_path is None:
        return
    for log in sorted(tmp_path.rglob("*.log"))[:12]:
        text = log.read_text(errors="replace")
        if text.strip():
            report.sections.append((f"log {log.relative_to(tmp_path)}", text[-LOG_TAIL:]))
