"""The web page at `/`, in real headless Chromium (Debian's /usr/bin/chromium, driven by
Playwright) against a real `floorplan serve` process on loopback (conftest.py here):
examples solved live, bad input, a dropped stream, API keys, variants and edits. The
brief form, the verdict, variants, edits and the phone width are in test_brief.py."""

from __future__ import annotations

import contextlib
import json
import re
import socket
import threading
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from floorplan.models import Problem
from tests.browser import click_room
from tests.paths import EXAMPLES
from tests.servers import Server
from tests.service.web.conftest import (
    JOB_TIMEOUT_MS,
    download,
    expect,
    pick_example,
    screenshot,
)

APARTMENT_ROOMS = ["foyer", "living", "kitchen", "bedroom", "bathroom"]
API_KEY = "web-test-key"

# Records every drawing of the plan as [source, rooms drawn], from the page's own
# data-drawn counter, so the test sees the incumbents go by however fast they come.
RECORD_DRAWINGS = """() => {
  window.drawings = [];
  const plan = document.getElementById("plan");
  new MutationObserver(() => window.drawings.push(
      [plan.dataset.source, plan.querySelectorAll(".room").length]))
    .observe(plan, { attributes: true, attributeFilter: ["data-drawn"] });
}"""


def test_the_examples_are_listed_smallest_first_and_served_as_written(server: Server) -> None:
    listed = httpx.get(f"{server.url}/v1/examples", timeout=10).json()["data"]
    names = [e["name"] for e in listed]
    assert names[0] == "apartment-5" and "house-13" in names
    assert [e["rooms"] for e in listed] == sorted(e["rooms"] for e in listed)
    for example in listed:
        served = httpx.get(f"{server.url}{example['href']}", timeout=10)
        assert served.headers["content-type"] == "application/json"
        assert served.text == (EXAMPLES / f"{example['name']}.json").read_text()
        assert Problem.model_validate_json(served.text).room_count == example["rooms"]
    unknown = httpx.get(f"{server.url}/v1/examples/no-such-plan", timeout=10)
    assert unknown.status_code == 404
    assert unknown.headers["content-type"] == "application/problem+json"
    assert unknown.json()["type"] == "/docs/problems/example-not-found"
    layout = httpx.get(f"{server.url}/v1/examples/apartment-5.layout", timeout=10)
    assert layout.status_code == 422  # not a name: results are not offered as problems


def test_the_page_and_its_files_are_served_with_a_strict_policy(server: Server) -> None:
    page = httpx.get(f"{server.url}/", timeout=10)
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert "default-src 'self'" in page.headers["content-security-policy"]
    assert 'src="static/app.js"' in page.text and 'href="static/style.css"' in page.text
    for asset, kind in (("app.js", "javascript"), ("events.js", "javascript"),
                        ("plan.js", "javascript"), ("style.css", "text/css")):
        served = httpx.get(f"{server.url}/static/{asset}", timeout=10)
        assert served.status_code == 200 and kind in served.headers["content-type"]
    missing = httpx.get(f"{server.url}/static/nothing.js", timeout=10)
    assert missing.status_code == 404
    assert missing.headers["content-type"] == "application/problem+json"


@pytest.mark.slow
def test_an_example_redraws_live_then_reports_and_downloads(page: Any, server: Server) -> None:
    page.goto(server.url)
    expect(page.locator("#status")).to_have_text("idle")
    pick_example(page, "apartment-5", time_limit="3")
    page.evaluate(RECORD_DRAWINGS)
    page.click("#submit")

    expect(page.locator("#status")).to_have_text("succeeded", timeout=JOB_TIMEOUT_MS)
    expect(page.locator("#summary")).to_be_visible()
    drawings = page.evaluate("window.drawings")
    live = [rooms for source, rooms in drawings if source == "incumbent"]
    assert live and max(live) > 0, drawings  # the incumbent was drawn while solving
    assert drawings[-1] == ["result", 5], drawings
    for room in APARTMENT_ROOMS:
        expect(page.locator(f"#plan .room[data-room='{room}'] .label")).to_contain_text(room)
    assert page.locator("#plan .door").count() > 0
    for field in ("level", "objective", "elapsed"):
        expect(page.locator(f"#{field}")).not_to_have_text("–")
    expect(page.locator("#elapsed")).to_have_text(re.compile(r"^\d+\.\d s$"))

    term = page.locator("#summary-list dd")
    expect(term.and_(page.locator("[data-term='coverage']"))).to_have_text(
        re.compile(r"^\d+\.\d %$"))
    # "yes" by the rules, then any goal missed (coverage below 99 %)
    expect(term.and_(page.locator("[data-term='valid']"))).to_have_text(re.compile(r"^yes"))
    expect(term.and_(page.locator("[data-term='termination']"))).to_have_text(
        re.compile("^(optimal|timelimit)$"))
    expect(term.and_(page.locator("[data-term='rooms placed']"))).to_have_text("5 of 5")
    expect(page.locator("#messages")).to_be_hidden()
    screenshot(page, "web-page.png")

    name, svg = download(page, "#download-svg")
    assert name == "apartment-5.svg" and "<svg" in svg and "bedroom" in svg
    name, dxf = download(page, "#download-dxf")
    assert name == "apartment-5.dxf" and "ENTITIES" in dxf
    name, geojson = download(page, "#download-geojson")
    features = json.loads(geojson)["features"]
    assert name == "apartment-5.geojson"
    assert {f["properties"].get("id") for f in features} >= set(APARTMENT_ROOMS)
    name, ifc = download(page, "#download-ifc")
    assert name == "apartment-5.ifc" and "FILE_SCHEMA(('IFC4'))" in ifc and "IFCSPACE" in ifc
    name, layout = download(page, "#download-json")
    assert name == "apartment-5.layout.json" and json.loads(layout)["report"]["valid"]


@pytest.mark.slow
def test_bad_input_shows_every_field_path_and_the_findings(page: Any, server: Server) -> None:
    page.goto(server.url)
    page.click("#json-view summary")  # the brief as JSON, behind "Advanced"
    page.fill("#problem", '{"boundary": [[0, 0], [6, 0], [6, 4]')
    page.click("#submit")
    expect(page.locator("#messages")).to_contain_text("not valid JSON")

    bad = {"boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
           "rooms": [{"id": "a", "min_size": [-1, 2]}, {"id": "", "type": "bedroom"}]}
    page.fill("#problem", json.dumps(bad))
    page.click("#submit")
    messages = page.locator("#messages")
    expect(messages).to_contain_text("(422)")
    expect(messages.locator("code", has_text="rooms.0.min_size")).to_have_count(1)
    expect(messages.locator("code", has_text="rooms.1.id")).to_have_count(1)
    expect(page.locator("#submit")).to_be_enabled()
    expect(page.locator("#status")).to_have_text("idle")  # nothing was queued

    too_small = {"boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
                 "rooms": [{"id": r, "min_size": [4, 4]} for r in "ab"]}
    page.fill("#problem", json.dumps(too_small))
    page.click("#validate")
    expect(messages).to_contain_text("No layout can exist")
    expect(messages.locator("li")).not_to_have_count(0)
    page.click("#submit")  # solved anyway: the job fails, and the page says why
    expect(page.locator("#status")).to_have_text("failed", timeout=JOB_TIMEOUT_MS)
    expect(page.locator("#summary-list [data-term='termination']")).to_have_text("infeasible")
    expect(messages).to_contain_text("No layout: infeasible")
    expect(messages.locator("li")).not_to_have_count(0)


class Relay:
    """A TCP relay in front of a server that can cut every connection through it at
    once, as a dropped network would: the page must resume its event stream."""

    def __init__(self, target_port: int) -> None:
        self.target_port = target_port
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self.listener.getsockname()[1]}"
        self._open: list[socket.socket] = []
        self._lock = threading.Lock()
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self.listener.accept()
            except OSError:
                return  # closed
            upstream = socket.create_connection(("127.0.0.1", self.target_port))
            with self._lock:
                self._open += [client, upstream]
            for source, sink in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pipe, args=(source, sink), daemon=True).start()

    @staticmethod
    def _pipe(source: socket.socket, sink: socket.socket) -> None:
        try:
            while data := source.recv(1 << 16):
                sink.sendall(data)
        except OSError:
            pass
        finally:
            for end in (source, sink):
                end.close()

    def cut(self) -> None:
        with self._lock:
            ends, self._open = self._open, []
        for end in ends:
            with contextlib.suppress(OSError):  # already closed by its pipe
                end.shutdown(socket.SHUT_RDWR)
            end.close()

    def close(self) -> None:
        self.listener.close()
        self.cut()


@pytest.mark.slow
def test_a_dropped_stream_resumes_and_cancel_keeps_the_best_layout(
    page: Any, server: Server
) -> None:
    relay = Relay(server.port)
    streams: list[str | None] = []
    page.on("request", lambda r: streams.append(r.headers.get("last-event-id"))
            if r.url.endswith("/events") else None)
    try:
        page.goto(relay.url)
        pick_example(page, "house-13", time_limit="60")
        page.click("#submit")
        expect(page.locator("#plan")).to_have_attribute("data-source", "incumbent",
                                                         timeout=JOB_TIMEOUT_MS)
        expect(page.locator("#cancel")).to_be_enabled()
        screenshot(page, "web-live.png")

        with page.expect_request(lambda r: r.url.endswith("/events")
                                 and "last-event-id" in r.headers):
            relay.cut()
        assert streams[0] is None and streams[-1] and streams[-1].isdigit(), streams
        page.click("#cancel")
        # The end of the job comes through the resumed stream.
        expect(page.locator("#status")).to_have_text("canceled", timeout=JOB_TIMEOUT_MS)
        summary = page.locator("#summary-list")
        expect(summary.locator("[data-term='termination']")).to_have_text("interrupted")
        expect(summary.locator("[data-term='rooms placed']")).to_have_text(
            re.compile(r" of 13$"))
        expect(page.locator("#plan")).to_have_attribute("data-source", "result")
        expect(page.locator("#download-svg")).to_have_attribute("href",
                                                                re.compile("format=svg"))
        expect(page.locator("#submit")).to_be_enabled()
        expect(page.locator("#messages")).to_be_hidden()
        screenshot(page, "web-canceled.png")
    finally:
        relay.close()


@pytest.mark.slow
def test_a_server_with_keys_asks_for_one_and_works_with_it(
    page: Any, tmp_path: Path
) -> None:
    keyed = Server(tmp_path, WORKERS="1", FLOORPLAN_API_KEYS=API_KEY).start()
    try:
        page.goto(keyed.url)
        expect(page.locator("#key-note")).to_have_text(re.compile("requires an API key"))
        expect(page.locator("#api-key")).to_be_focused()
        page.set_input_files("#file", EXAMPLES / "apartment-5.json")  # an upload this time
        expect(page.locator("#problem")).to_have_value(re.compile('"name": "apartment-5"'))
        page.fill("#time-limit", "3")
        page.click("#submit")
        expect(page.locator("#messages")).to_contain_text("(401)")

        page.fill("#api-key", API_KEY)
        page.click("#submit")
        expect(page.locator("#status")).to_have_text("succeeded", timeout=JOB_TIMEOUT_MS)
        expect(page.locator("#plan .room")).to_have_count(5)
        # The link needs the key too: the page fetches the file with it and saves that.
        name, geojson = download(page, "#download-geojson")
        assert name == "apartment-5.geojson"
        assert json.loads(geojson)["type"] == "FeatureCollection"

        # A reload follows the same job again, with the key kept for the tab.
        page.reload()
        expect(page.locator("#status")).to_have_text("succeeded", timeout=JOB_TIMEOUT_MS)
        # "yes" by the rules, then any goal missed (coverage below 99 %)
        expect(page.locator("#summary-list [data-term='valid']")).to_have_text(re.compile(r"^yes"))
        expect(page.locator("#plan .room")).to_have_count(5)
    finally:
        keyed.stop()


@pytest.mark.slow
def test_variants_pick_fix_rooms_edit_a_target_resolve_compare_and_undo(
        page: Any, server: Server) -> None:
    page.goto(server.url)
    pick_example(page, "apartment-5", time_limit="1")
    page.fill("#variants", "2")
    page.click("#submit")
    expect(page.locator("#status")).to_have_text("succeeded", timeout=JOB_TIMEOUT_MS)
    expect(page.locator("#explore")).to_be_visible()
    thumbs = page.locator("#variants-strip .variant-thumb")
    if thumbs.count() > 1:  # side by side, best first; a click puts one on the plan
        expect(thumbs.first).to_have_attribute("aria-pressed", "true")
        thumbs.nth(1).click()
        expect(thumbs.nth(1)).to_have_attribute("aria-pressed", "true")
        expect(page.locator("#plan")).to_have_attribute("data-source", "explore")
    kept = ["living", "bedroom", "foyer"]
    before = {room: page.locator(f"#plan .room[data-room='{room}'] polygon")
              .get_attribute("points") for room in kept}
    for room in kept:
        click_room(page, room)
        expect(page.locator(f"#plan .room[data-room='{room}']")).to_have_class(
            re.compile("locked"))
    expect(page.locator("#locked-count")).to_have_text("3")
    page.uncheck("#keep-others")  # only the rooms fixed by hand are sent fixed
    # The kitchen's target, 10 % smaller per side, in place.
    page.select_option("#edit-room", "kitchen")
    page.uncheck("#hold-size")  # a target only
    width = float(page.input_value("#target-width"))
    page.fill("#target-width", f"{0.9 * width:.2f}")
    page.click("#apply-target")
    expect(page.locator("#edit-note")).to_contain_text("kitchen: target")
    page.click("#resolve")

    expect(page.locator("#compare")).to_be_visible(timeout=JOB_TIMEOUT_MS)
    expect(page.locator("#status")).to_have_text("succeeded")
    sent = json.loads(page.input_value("#problem"))
    assert sorted(r["id"] for r in sent["rooms"] if "fixed" in r) == sorted(kept)
    assert next(r for r in sent["rooms"] if r["id"] == "kitchen")["target_size"][0] == \
        pytest.approx(0.9 * width, abs=0.01)
    assert {r["id"] for r in sent["options"]["start"]} == set(APARTMENT_ROOMS)
    for room, points in before.items():  # kept exactly, and still drawn locked
        plan_room = page.locator(f"#plan .room[data-room='{room}']")
        expect(plan_room).to_have_class(re.compile("locked"))
        # The same vertices; the service may start the ring at another one.
        assert sorted(plan_room.locator("polygon").get_attribute("points").split()) == \
            sorted(points.split())
    expect(page.locator("#previous-plan .room")).to_have_count(5)
    expect(page.locator("#changes li").first).to_be_visible()
    expect(page.locator("#edit-note")).to_contain_text("Re-solved")
    # "yes" by the rules, then any goal missed (coverage below 99 %)
    expect(page.locator("#summary-list dd[data-term='valid']")).to_have_text(re.compile(r"^yes"))
    screenshot(page, "web-explore.png")

    page.click("#undo")  # back to the plan before the edit: nothing to compare
    expect(page.locator("#compare")).to_be_hidden()
    expect(page.locator("#locked-count")).to_have_text("3")
    page.click("#undo")  # and before the target's change
    expect(page.locator("#undo")).to_be_disabled()


def test_corridors_their_exits_and_routes_are_drawn(page: Any, server: Server) -> None:
    """A brief with `corridors`: its exits and route are drawn from the brief before any
    solve; the result's corridors are drawn as covered floor, one shape per corridor of
    the layout the API returns."""
    brief = {
        "name": "corridor-page",
        "boundary": [[0, 0], [30, 0], [30, 12], [0, 12]],
        "rooms": [{"id": f"o{k}", "type": "office", "target_size": [3.6, 3.2],
                   "min_size": [2.0, 2.0]} for k in range(10)],
        "corridors": {"exits": [[0, 6], [30, 6]], "width": 1.8, "max_travel": 30,
                      "routes": [{"between": [[2, 2], [28, 10]]}]},
    }
    page.goto(server.url)
    page.click("#json-view summary")
    page.fill("#problem", json.dumps(brief))
    plan = page.locator("#plan")
    expect(plan.locator(".exit")).to_have_count(2)
    expect(plan.locator(".route")).to_have_count(1)
    page.fill("#time-limit", "20")
    page.click("#submit")
    expect(page.locator("#status")).to_have_text("succeeded", timeout=2 * JOB_TIMEOUT_MS)
    expect(plan).to_have_attribute("data-source", "result")
    listed = httpx.get(f"{server.url}/v1/layouts", timeout=10).json()["data"]
    layout = httpx.get(f"{server.url}/v1/layouts/{listed[0]['id']}/result", timeout=10).json()
    assert layout["corridors"]
    expect(plan.locator(".corridor")).to_have_count(len(layout["corridors"]))
    expect(plan.locator(".exit")).to_have_count(2)
