"""Screenshots of the web page, one per step an architect takes, for docs/web.md: a
`floorplan serve` of its own on a free loopback port (a temporary store), driven in
Debian's headless Chromium through Playwright, as the browser tests drive it.

    python scripts/web_screenshots.py [docs/]

Steps: a T-shaped outline by its dimensions with the entrance clicked on it, a shaft
dropped on the plan and north turned 15 degrees; an outline being drawn on the grid; the
rooms with the adjacency matrix and the bubble diagram; the solved plan with its verdict
and room table; the variants side by side with a favourite starred and named; an edit
(the bath fixed, bed2's east wall dragged 0.3 m out) re-solved beside the plan before;
the phone width.
It prints what each step measured (rooms changed by the edit, the page's width at 390 px).
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx2 as httpx
from playwright.sync_api import expect, sync_playwright
from shapely.geometry import Polygon

# The page's helpers shared with its browser tests (tests/browser.py).
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.browser import CHROMIUM, click_plan, plan_point

ROWS = "[data-testid=room-row]"
SOLVE_TIMEOUT_MS = 300_000


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def serve(data_dir: Path) -> tuple[subprocess.Popen[bytes], str]:
    port = free_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "floorplan.service", "serve", "--port", str(port),
         "--data-dir", str(data_dir), "--workers", "1", "--log-level", "warning"],
        env=dict(os.environ), start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"{url}/readyz", timeout=1).status_code == 200:
                return process, url
        except httpx.TransportError:
            pass
        if process.poll() is not None:
            raise SystemExit(f"the server exited with {process.returncode}")
        time.sleep(0.2)
    process.terminate()
    raise SystemExit("the server did not become ready")


def solve(tab: Any) -> None:
    with tab.expect_response(lambda r: r.request.method == "POST"
                             and r.url.endswith("/v1/layouts")) as posted:
        tab.click("[data-testid=solve]")
    job = posted.value.json()["id"]
    expect(tab.locator(f"#status[data-job='{job}']")).to_have_text(
        "succeeded", timeout=SOLVE_TIMEOUT_MS)
    expect(tab.locator("#summary")).to_be_visible()


def shown_layout(tab: Any, url: str) -> dict[str, Any]:
    """The layout the page shows, as its layout-JSON link serves it."""
    href = tab.get_attribute("[data-testid=download-json]", "href")
    return httpx.get(f"{url}/{href}", timeout=30).json()


def stability(before: dict[str, Any], after: dict[str, Any], *, fixed: str, widened: str) -> None:
    """Prints which rooms the edit moved against those it may move (the widened room and
    the rooms sharing a wall with it, as the page counts them), and whether every other
    room stayed exactly where it was."""
    polygons = {r["id"]: Polygon(r["polygon"]) for r in before["rooms"]}
    moved = {r["id"] for r in after["rooms"]
             if Polygon(r["polygon"]).symmetric_difference(polygons[r["id"]]).area > 1e-6}
    grown = polygons[widened].buffer(0.011, join_style="mitre")
    may_move = {r for r, p in polygons.items() if grown.intersection(p).area > 0.05 * 0.011}
    may_move.discard(fixed)
    print(f"moved: {sorted(moved)}; may move: {sorted(may_move)}; "
          f"the others stayed: {'yes' if moved <= may_move else 'NO'}")


def shoot(tab: Any, out: Path, name: str, selector: str | None = None) -> None:
    path = out / name
    if selector:
        tab.locator(selector).screenshot(path=str(path))
    else:
        tab.screenshot(path=str(path))
    print(f"{path}: {path.stat().st_size // 1024} KiB")


def steps(tab: Any, url: str, out: Path) -> None:
    tab.goto(url)
    tab.select_option("#example", "template:flat-6")
    expect(tab.locator(ROWS)).to_have_count(6)
    tab.select_option("[data-testid=outline-shape]", "t")
    tab.fill("[data-testid=outline-width]", "12")
    tab.fill("[data-testid=outline-depth]", "9")
    tab.fill("[data-testid=cut-width]", "2")
    tab.fill("[data-testid=cut-depth]", "3")
    tab.select_option("[data-testid=place-mode]", "entrance")
    click_plan(tab, 6.2, -0.2)
    tab.select_option("[data-testid=place-mode]", "obstacle")
    click_plan(tab, 11.2, 8.4)
    tab.select_option("[data-testid=place-mode]", "")
    tab.locator("[data-testid=obstacle-label]").fill("shaft")
    tab.fill("[data-testid=north]", "15")  # true north 15 degrees right of the plan's up
    tab.evaluate("window.scrollTo(0, 0)")
    shoot(tab, out, "web-1-outline.png")

    tab.select_option("[data-testid=place-mode]", "outline")
    for x, y in ((0, 0), (8, 0), (8, 4), (11, 4)):
        click_plan(tab, x, y)
    shoot(tab, out, "web-2-draw.png", "#plan")
    tab.click("#cancel-drawing")

    for a, b in (("kitchen", "living"), ("hall", "living")):
        tab.locator(f"[data-testid=adjacency-pair][data-pair='{min(a, b)}|{max(a, b)}']").check()
    for room in ("bed1", "bath"):  # a pair in the bubble diagram: one bubble, then the other
        tab.locator(f"[data-testid=bubble][data-room={room}]").click()
    tab.locator(ROWS).nth(1).locator("[data-testid=room-area]").fill("30")
    shoot(tab, out, "web-3-rooms.png", "#rooms-box")

    tab.fill("#time-limit", "20")
    tab.fill("#variants", "3")
    solve(tab)
    tab.evaluate("window.scrollTo(0, 0)")
    shoot(tab, out, "web-4-solved.png")
    shoot(tab, out, "web-5-verdict.png", "#summary")

    rows = tab.locator("[data-testid=variant-row]")
    if rows.count() >= 2:
        rows.nth(1).locator("[data-testid=variant-star]").click()
        rows.nth(1).locator("[data-testid=variant-name]").fill("living south")
        rows.nth(0).locator("[data-testid=variant-star]").click()
        rows.nth(0).locator("[data-testid=variant-name]").fill("best score")
        shoot(tab, out, "web-6-variants.png", "#explore")
    else:
        print("one variant only: no variants table to show")

    before = shown_layout(tab, url)
    tab.click("#plan .room[data-room='bath']")
    tab.select_option("#edit-room", "bed2")
    # Its east wall dragged 0.3 m out: at least that wide ("at least" ticked).
    bed2 = next(r for r in before["rooms"] if r["id"] == "bed2")
    east = max(x for x, _ in bed2["polygon"])
    middle = sum(y for _, y in bed2["polygon"]) / len(bed2["polygon"])
    tab.locator("#plan").scroll_into_view_if_needed()
    handle = tab.locator("#plan .handles .handle.east").bounding_box()
    tab.mouse.move(handle["x"] + handle["width"] / 2, handle["y"] + handle["height"] / 2)
    tab.mouse.down()
    tab.mouse.move(*plan_point(tab, east + 0.31, middle), steps=4)
    tab.mouse.up()
    print("bed2 set to:", tab.input_value("#target-width"), "x", tab.input_value("#target-depth"))
    tab.click("#resolve")
    # Done when the note no longer says it is re-solving (a layout, or none found).
    expect(tab.locator("#edit-note")).not_to_contain_text("Re-solving", timeout=SOLVE_TIMEOUT_MS)
    print("edit:", tab.inner_text("#edit-note"))
    stability(before, shown_layout(tab, url), fixed="bath", widened="bed2")
    shoot(tab, out, "web-7-edit.png", "#output")

    tab.set_viewport_size({"width": 390, "height": 844})
    tab.evaluate("window.scrollTo(0, 0)")
    print("width at 390 px:", tab.evaluate("document.documentElement.scrollWidth"))
    shoot(tab, out, "web-8-phone.png")


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "docs")
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as data:
        process, url = serve(Path(data))
        try:
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(executable_path=str(CHROMIUM), headless=True)
                try:
                    context = browser.new_context(viewport={"width": 1280, "height": 860},
                                                  accept_downloads=True)
                    steps(context.new_page(), url, out)
                finally:
                    browser.close()
        finally:
            process.terminate()
            process.wait(timeout=30)


if __name__ == "__main__":
    main()
