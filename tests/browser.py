"""Debian's Chromium for the browser tests (the web page, the docs pages), driven by
Playwright: never a downloaded build. Without it the tests skip, saying why; under CI
(the CI variable set) they fail instead, so that a missing install cannot pass for a
green run."""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = Path("/usr/bin/chromium")


def browser_missing() -> str | None:
    """Why the browser tests cannot run here, or None."""
    if importlib.util.find_spec("playwright") is None:
        return "the playwright package is not installed (it is in the dev extra)"
    if not CHROMIUM.exists():
        return f"{CHROMIUM} is missing: apt-get install -y chromium chromium-driver"
    return None


@contextmanager
def headless_chromium() -> Iterator[Any]:
    """A headless Chromium browser, or the test skipped (failed under CI)."""
    missing = browser_missing()
    if missing:
        if os.environ.get("CI"):
            pytest.fail(f"the browser tests must run in CI: {missing}")
        pytest.skip(missing)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=str(CHROMIUM), headless=True)
        try:
            yield chromium
        finally:
            chromium.close()


def plan_point(tab: Any, x: float, y: float) -> tuple[float, float]:
    """Where the web page's plan shows the point (x, y) in metres (y north), in the
    viewport's pixels, through the drawing's own transform."""
    at = tab.evaluate("""([x, y]) => {
      const svg = document.getElementById("plan");
      const p = svg.createSVGPoint();
      p.x = x; p.y = -y;
      const s = p.matrixTransform(svg.getScreenCTM());
      return [s.x, s.y];
    }""", [x, y])
    return float(at[0]), float(at[1])


def click_plan(tab: Any, x: float, y: float) -> None:
    """Clicks the web page's plan at the point (x, y) in metres (y north) (the browser
    tests and scripts/web_screenshots.py)."""
    tab.locator("#plan").scroll_into_view_if_needed()
    tab.mouse.click(*plan_point(tab, x, y))


def click_room(tab: Any, room: str) -> None:
    """Clicks a point inside the plan's room `room`: Playwright's own click aims at the
    middle of the room's box, which for an L-shaped room may lie in a neighbour."""
    import shapely

    ring = tab.locator(f"#plan .room[data-room='{room}'] polygon").first.get_attribute("points")
    svg = [tuple(float(v) for v in p.split(",")) for p in ring.split()]
    inside = shapely.Polygon([(x, -y) for x, y in svg]).representative_point()
    click_plan(tab, inside.x, inside.y)
