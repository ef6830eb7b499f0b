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
