"""The brief editor's shapes and pickers in headless Chromium against a real server: U
and T outlines by their dimensions, the entrance at a side's middle or clicked on the
outline, obstacles as rows and dropped on the plan, an outline drawn on the snapping
grid (by mouse and by keyboard), and adjacencies ticked per pair in the matrix (by mouse
and by keyboard); the server's validation accepts what the editor made, and nothing
overflows at 390 px."""

from __future__ import annotations

import json
from typing import Any

import pytest

from tests.browser import click_plan
from tests.servers import Server
from tests.service.web.conftest import ROWS, expect, open_six_room_flat, screenshot


def brief(tab: Any) -> dict[str, Any]:
    return json.loads(tab.input_value("#problem"))


@pytest.mark.slow
def test_outlines_entrance_obstacles_drawing_and_the_adjacency_matrix_make_a_valid_brief(
        page: Any, server: Server) -> None:
    open_six_room_flat(page, server.url)

    page.select_option("[data-testid=outline-shape]", "u")
    page.fill("[data-testid=outline-width]", "12")
    page.fill("[data-testid=cut-width]", "4")
    page.fill("[data-testid=cut-depth]", "3")
    expect(page.locator("#cut-width-label")).to_have_text("Notch width")
    assert brief(page)["boundary"] == [[0, 0], [12, 0], [12, 8], [8, 8], [8, 5], [4, 5],
                                       [4, 8], [0, 8]]
    page.select_option("#entrance-side", "north")  # the middle of a north arm, on the wall
    assert brief(page)["entrance"] == [10, 8]

    page.select_option("[data-testid=outline-shape]", "t")
    t_shape = [[4, 0], [8, 0], [8, 3], [12, 3], [12, 8], [0, 8], [0, 3], [4, 3]]
    assert brief(page)["boundary"] == t_shape
    page.select_option("#entrance-side", "south")
    assert brief(page)["entrance"] == [6, 0]
    page.reload()  # the JSON view read back into the form: still a T
    page.select_option("#example", "template:flat-6")
    page.click("#json-view summary")
    changed = {**brief(page), "boundary": t_shape, "entrance": [6, 0]}
    page.fill("#problem", json.dumps(changed))
    expect(page.locator("[data-testid=outline-shape]")).to_have_value("t")
    expect(page.locator("[data-testid=cut-width]")).to_have_value("4")

    # The entrance clicked near the east wall lands on it, to the decimetre.
    page.select_option("[data-testid=place-mode]", "entrance")
    click_plan(page, 12.3, 6.26)
    assert brief(page)["entrance"] == [12, 6.3]
    expect(page.locator("#entrance-side")).to_have_value("custom")
    expect(page.locator("[data-testid=place-mode]")).to_have_value("")

    # Obstacles: one typed in a row, one dropped on the plan (snapped to the grid).
    page.click("[data-testid=add-obstacle]")
    row = page.locator("[data-testid=obstacle-row]").first
    for name, value in (("x", "5"), ("y", "6"), ("width", "0.6"), ("depth", "0.6"),
                        ("label", "shaft")):
        row.locator(f"[data-testid=obstacle-{name}]").fill(value)
    page.select_option("[data-testid=place-mode]", "obstacle")
    click_plan(page, 2.2, 6.3)
    page.select_option("[data-testid=place-mode]", "")
    assert brief(page)["obstacles"] == [
        {"x": 5, "y": 6, "width": 0.6, "depth": 0.6, "label": "shaft"},
        {"x": 1.5, "y": 6, "width": 1, "depth": 1}]
    expect(page.locator("#plan .obstacle")).to_have_count(2)
    # One moved off the outline: refused as you type, on its row and on the plan.
    row.locator("[data-testid=obstacle-x]").fill("20")
    expect(page.locator("#plan .obstacle.invalid")).to_have_count(1, timeout=10_000)
    expect(row.locator(".field-errors")).not_to_be_empty()
    row.locator("[data-testid=obstacle-x]").fill("5")
    expect(page.locator("#plan .obstacle.invalid")).to_have_count(0, timeout=10_000)

    # Adjacencies per pair: a tick is the pair in "Next to", and back.
    pair = page.locator("[data-testid=adjacency-pair][data-a=bed1][data-b=bath]")
    pair.check()
    assert {"a": "bed1", "b": "bath"} in brief(page)["adjacency"]
    expect(page.locator(ROWS).nth(3).locator("[data-testid=room-next]")).to_have_value("bath")
    page.locator(ROWS).nth(2).locator("[data-testid=room-next]").fill("living")
    expect(page.locator("[data-testid=adjacency-pair][data-a=living][data-b=kitchen]")).to_be_checked()
    pair.focus()
    page.keyboard.press("Space")  # by keyboard: unticked, and the focus stays on it
    assert {"a": "bed1", "b": "bath"} not in brief(page).get("adjacency", [])
    assert page.evaluate("document.activeElement.dataset.pair") == "bath|bed1"
    page.keyboard.press("Space")
    assert {"a": "bed1", "b": "bath"} in brief(page)["adjacency"]

    page.click("#validate")
    expect(page.locator("#messages")).to_contain_text("No problem found")
    screenshot(page, "web-editor.png")
    page.set_viewport_size({"width": 390, "height": 844})
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
    page.set_viewport_size({"width": 1280, "height": 860})

    # An outline drawn on the 0.5 m grid: corners snapped and squared, closed on the first.
    page.locator("#obstacle-rows button").first.click()
    page.locator("#obstacle-rows button").first.click()
    page.select_option("[data-testid=place-mode]", "outline")
    expect(page.locator("#plan")).to_have_attribute("data-source", "board")
    for x, y in ((0.1, 0.2), (8.2, -0.1), (8.1, 4.1), (10.2, 3.9), (9.9, 7.2), (0.2, 6.8),
                 (0.1, 0.1)):
        click_plan(page, x, y)
    assert brief(page)["boundary"] == [[0, 0], [8, 0], [8, 4], [10, 4], [10, 7], [0, 7]]
    expect(page.locator("[data-testid=outline-shape]")).to_have_value("other")
    expect(page.locator("#draw-controls")).to_be_hidden()
    page.select_option("#entrance-side", "south")
    page.click("#validate")
    expect(page.locator("#messages")).to_contain_text("No problem found")

    # The same board by keyboard: arrows move the cross a grid step, Enter puts a corner.
    page.select_option("[data-testid=place-mode]", "outline")
    assert page.evaluate("document.activeElement.id") == "plan"
    for key, times in (("Enter", 1), ("ArrowRight", 12), ("Enter", 1), ("ArrowUp", 8),
                       ("Enter", 1), ("ArrowLeft", 12), ("Enter", 1), ("ArrowDown", 8),
                       ("Enter", 1)):
        for _ in range(times):
            page.keyboard.press(key)
    assert brief(page)["boundary"] == [[0, 0], [6, 0], [6, 4], [0, 4]]
    expect(page.locator("[data-testid=outline-shape]")).to_have_value("rectangle")
    expect(page.locator("[data-testid=outline-width]")).to_have_value("6")


@pytest.mark.slow
def test_north_is_set_in_the_editor_turns_the_arrow_and_the_sides_and_is_checked(
        page: Any, server: Server) -> None:
    open_six_room_flat(page, server.url)
    page.select_option("[data-testid=outline-shape]", "rectangle")
    page.fill("[data-testid=outline-width]", "10")
    page.fill("[data-testid=outline-depth]", "8")
    arrow = page.locator("#plan g.north")
    expect(arrow).to_have_attribute("data-north", "0")
    assert "north" not in brief(page)  # the default is left out
    page.select_option("#entrance-side", "north")
    assert brief(page)["entrance"] == [5, 8]

    # North along the plan's +x: the brief says so, the arrow turns a quarter clockwise,
    # and the entrance "in the middle of the north side" moves to the plan's east side.
    page.fill("[data-testid=north]", "90")
    assert brief(page)["north"] == 90
    expect(arrow).to_have_attribute("data-north", "90")
    assert (arrow.get_attribute("transform") or "").startswith("rotate(90 ")
    assert brief(page)["entrance"] == [10, 4]
    page.click("#validate")
    expect(page.locator("#messages")).to_contain_text("No problem found")
    page.reload()  # read back from the JSON view: the field and the side as they were
    page.select_option("#example", "template:flat-6")
    page.click("#json-view summary")
    page.fill("#problem", json.dumps({**brief(page), "boundary": [[0, 0], [10, 0], [10, 8],
                                      [0, 8]], "north": 90, "entrance": [10, 4]}))
    expect(page.locator("[data-testid=north]")).to_have_value("90")
    expect(page.locator("#entrance-side")).to_have_value("north")

    # Out of a turn: refused as you type, on the field, saying what to write.
    page.fill("[data-testid=north]", "400")
    expect(page.locator("[data-testid=north]")).to_have_attribute("aria-invalid", "true",
                                                                  timeout=10_000)
    expect(page.locator("#outline-errors")).to_contain_text("360")
    page.fill("[data-testid=north]", "330")
    expect(page.locator("[data-testid=north]")).not_to_have_attribute("aria-invalid", "true",
                                                                      timeout=10_000)
    assert brief(page)["north"] == 330


@pytest.mark.slow
def test_a_programme_line_adds_that_many_rooms_and_a_target_takes_an_area_or_a_size(
        page: Any, server: Server) -> None:
    open_six_room_flat(page, server.url)
    page.select_option("[data-testid=add-type]", "bedroom")
    page.fill("[data-testid=add-count]", "2")
    page.click("[data-testid=add-room]")
    expect(page.locator(ROWS)).to_have_count(8)
    rooms = brief(page)["rooms"]
    assert [(r["id"], r["type"]) for r in rooms[6:]] == [("bedroom1", "bedroom"),
                                                        ("bedroom2", "bedroom")]
    expect(page.locator("[data-testid=add-count]")).to_have_value("1")
    page.select_option("[data-testid=add-type]", "study")
    page.click("[data-testid=add-room]")  # one: left for its name
    expect(page.locator(ROWS)).to_have_count(9)
    assert brief(page)["rooms"][8]["type"] == "study" and "id" not in brief(page)["rooms"][8]
    page.locator(ROWS).nth(8).locator("[data-testid=room-name]").fill("study")

    # A target as width x depth is sent as such; an area as a square the template shapes.
    page.locator(ROWS).nth(6).locator("[data-testid=room-area]").fill("3.2 x 4")
    page.locator(ROWS).nth(7).locator("[data-testid=room-area]").fill("12.25")
    rooms = brief(page)["rooms"]
    assert rooms[6]["target_size"] == [3.2, 4] and rooms[7]["target_size"] == [3.5, 3.5]
    page.fill("[data-testid=outline-width]", "14")
    page.click("#validate")
    expect(page.locator("#messages")).to_contain_text("No problem found")


@pytest.mark.slow
def test_the_bubble_diagram_pairs_rooms_like_the_matrix_by_mouse_and_by_keyboard(
        page: Any, server: Server) -> None:
    open_six_room_flat(page, server.url)
    bubbles = page.locator("[data-testid=bubble]")
    expect(bubbles).to_have_count(6)
    bed1, bath = (page.locator(f"[data-testid=bubble][data-room={n}]") for n in ("bed1", "bath"))
    # A bigger target, a bigger bubble.
    page.locator(ROWS).nth(1).locator("[data-testid=room-area]").fill("40")
    page.locator(ROWS).nth(5).locator("[data-testid=room-area]").fill("4")
    living = float(page.locator("[data-room=living] circle").get_attribute("r"))
    assert living > float(bath.locator("circle").get_attribute("r"))

    bed1.click()
    expect(bed1).to_have_attribute("aria-pressed", "true")
    bath.click()
    assert {"a": "bed1", "b": "bath"} in brief(page)["adjacency"]
    expect(page.locator("[data-testid=adjacency-pair][data-a=bed1][data-b=bath]")).to_be_checked()
    expect(page.locator("#bubbles .bond[data-pair='bath|bed1']")).to_have_count(1)
    expect(page.locator("#bubble-note")).to_contain_text("bed1 and bath paired")

    # By keyboard: Enter on bath, then on bed1, unpairs them; the focus stays on bed1.
    bath.focus()
    page.keyboard.press("Enter")
    page.locator("[data-testid=bubble][data-room=bed1]").focus()
    page.keyboard.press("Enter")
    assert {"a": "bed1", "b": "bath"} not in brief(page).get("adjacency", [])
    expect(page.locator("[data-testid=adjacency-pair][data-a=bed1][data-b=bath]")).not_to_be_checked()
    expect(page.locator("#bubbles .bond[data-pair='bath|bed1']")).to_have_count(0)
    assert page.evaluate("document.activeElement.dataset.room") == "bed1"
    # A tick in the matrix is a line between the bubbles.
    page.locator("[data-testid=adjacency-pair][data-a=kitchen][data-b=bed2]").check()
    expect(page.locator("#bubbles .bond[data-pair='bed2|kitchen']")).to_have_count(1)
    page.set_viewport_size({"width": 390, "height": 844})
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
