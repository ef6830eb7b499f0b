"""The SVG drawing of a layout: well-formed, complete, escaped, and the right way up."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import pytest

from floorplan.models import Layout, Problem, Rect, Report, RoomLayout
from floorplan.solver.export.svg import PALETTE, render_svg, room_fill, scale_bar_length

NS = {"svg": "http://www.w3.org/2000/svg"}


def _room(room_id: str, room_type: str, x0: float, y0: float, x1: float, y1: float) -> RoomLayout:
    return RoomLayout(
        id=room_id, type=room_type,
        polygon=[(x0, y0), (x1, y0), (x1, y1), (x0, y1)],
        rectangles=[Rect(x=x0, y=y0, width=x1 - x0, depth=y1 - y0)],
        area=(x1 - x0) * (y1 - y0),
    )


@pytest.fixture
def problem() -> Problem:
    # 10 x 8 m with a shaft in the middle of the north half; entrance on the south wall.
    return Problem.model_validate({
        "name": "flat <&> \"one\"",
        "boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
        "obstacles": [{"x": 4, "y": 6, "width": 1, "depth": 1, "label": "shaft"}],
        "entrance": [5.0, 0.0],
        "rooms": [
            {"id": "living", "type": "living"},
            {"id": "bed<&>1", "type": "bedroom"},
            {"id": "wine", "type": "cellar"},
        ],
    })


@pytest.fixture
def layout() -> Layout:
    # The strip y in [4, 5] is left uncovered on purpose.
    rooms = [
        _room("living", "living", 0, 0, 6, 4),
        _room("bed<&>1", "bedroom", 6, 0, 10, 4),
        _room("wine", "cellar", 0, 5, 4, 8),
    ]
    return Layout(name="flat", rooms=rooms, report=Report(coverage=0.7, uncovered_area=24.0))


@pytest.fixture
def svg(problem: Problem, layout: Layout) -> ET.Element:
    return ET.fromstring(render_svg(problem, layout))


def _rooms(svg: ET.Element) -> dict[str, ET.Element]:
    return {g.get("data-id", ""): g for g in svg.iterfind(".//svg:g[@class='room']", NS)}


def _label_lines(group: ET.Element) -> list[str]:
    text = group.find("svg:text", NS)
    assert text is not None
    return [span.text or "" for span in text.iterfind("svg:tspan", NS)]


def _ys(polygon: ET.Element) -> list[float]:
    return [float(pair.split(",")[1]) for pair in polygon.get("points", "").split()]


def test_root_is_an_svg_document(problem: Problem, layout: Layout) -> None:
    text = render_svg(problem, layout)
    assert text.startswith("<?xml")
    root = ET.fromstring(text)
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    assert float(root.get("width", 0)) > 10 * 40  # the plan plus margins


def test_one_filled_shape_per_room_coloured_by_type(svg: ET.Element) -> None:
    rooms = _rooms(svg)
    assert set(rooms) == {"living", "bed<&>1", "wine"}
    expected = {"living": PALETTE["living"], "bed<&>1": PALETTE["bedroom"],
                "wine": room_fill("cellar")}
    for room_id, group in rooms.items():
        shapes = group.findall("svg:polygon", NS)
        assert len(shapes) == 1
        assert shapes[0].get("fill") == expected[room_id]


def test_unknown_types_get_a_stable_distinct_pastel() -> None:
    colour = room_fill("cellar")
    assert colour == room_fill("cellar") == room_fill(" Cellar ")
    assert colour not in PALETTE.values()
    red, green, blue = (int(colour[i:i + 2], 16) for i in (1, 3, 5))
    assert min(red, green, blue) > 150  # pastel: light in every channel


def test_labels_carry_id_and_area(svg: ET.Element) -> None:
    rooms = _rooms(svg)
    assert _label_lines(rooms["living"]) == ["living", "24.0 m²"]
    assert _label_lines(rooms["wine"]) == ["wine", "12.0 m²"]


def test_small_rooms_get_smaller_labels(problem: Problem) -> None:
    big, small = _room("big", "living", 0, 0, 6, 4), _room("tiny", "storage", 9, 7, 10, 8)
    layout = Layout(rooms=[big, small], report=Report(coverage=0.3, uncovered_area=50))
    rooms = _rooms(ET.fromstring(render_svg(problem, layout)))
    size = {k: float(g.find("svg:text", NS).get("font-size")) for k, g in rooms.items()}
    assert size["tiny"] < size["big"]


def test_user_text_is_escaped(problem: Problem, layout: Layout) -> None:
    text = render_svg(problem, layout)
    assert "bed&lt;&amp;&gt;1" in text
    assert "bed<&>1" not in text
    root = ET.fromstring(text)  # still well-formed
    assert _label_lines(_rooms(root)["bed<&>1"])[0] == "bed<&>1"
    title = root.find("svg:text[@class='title']", NS)
    assert title is not None and title.text == 'flat <&> "one"'


def test_control_characters_in_ids_keep_the_document_well_formed(problem: Problem) -> None:
    layout = Layout(rooms=[_room("a\x01b", "living", 0, 0, 2, 2)],
                    report=Report(coverage=0.05, uncovered_area=75))
    ET.fromstring(render_svg(problem, layout))


def test_obstacles_are_hatched_and_labelled(svg: ET.Element) -> None:
    pattern = svg.find(".//svg:defs/svg:pattern", NS)
    assert pattern is not None
    assert pattern.find("svg:line", NS) is not None
    obstacle = svg.find(".//svg:g[@class='obstacle']", NS)
    assert obstacle is not None
    rect = obstacle.find("svg:rect", NS)
    assert rect is not None and rect.get("fill") == f"url(#{pattern.get('id')})"
    assert "".join(obstacle.find("svg:text", NS).itertext()) == "shaft"


def test_uncovered_area_is_shown(svg: ET.Element, problem: Problem, layout: Layout) -> None:
    gaps = svg.findall(".//svg:path[@class='uncovered']", NS)
    assert len(gaps) == 1
    full = Layout(rooms=[_room("all", "living", 0, 0, 10, 8)],
                  report=Report(coverage=1, uncovered_area=0))
    # The shaft is not free area, so a room "covering" it leaves no visible gap either.
    assert ET.fromstring(render_svg(problem, full)).find(
        ".//svg:path[@class='uncovered']", NS) is None


def test_entrance_marker_only_with_an_entrance(svg: ET.Element, layout: Layout) -> None:
    assert svg.find(".//svg:g[@class='entrance']", NS) is not None
    bare = Problem.model_validate({"boundary": [[0, 0], [10, 0], [10, 8], [0, 8]],
                                   "rooms": [{"id": "living"}]})
    root = ET.fromstring(render_svg(bare, layout))
    assert root.find(".//svg:g[@class='entrance']", NS) is None


def test_scale_bar_has_a_round_label(svg: ET.Element) -> None:
    label = svg.find(".//svg:text[@class='scale-label']", NS)
    assert label is not None and label.text == "2 m"  # a fifth of 10 m
    assert svg.find(".//svg:g[@class='scale-bar']", NS) is not None


@pytest.mark.parametrize(("width", "length"), [(10, 2), (25, 5), (50, 10), (100, 20),
                                               (240, 50), (4, 1), (1.2, 0.2)])
def test_scale_bar_length_is_about_a_fifth(width: float, length: float) -> None:
    assert scale_bar_length(width) == pytest.approx(length)


def test_y_is_flipped(svg: ET.Element) -> None:
    rooms = _rooms(svg)
    south = _ys(rooms["living"].find("svg:polygon", NS))
    north = _ys(rooms["wine"].find("svg:polygon", NS))
    # The south room sits lower on the page: larger SVG y, and its south wall is the
    # bottom of the plan, 8 m below the top of the plan.
    assert min(south) > max(north)
    assert max(south) - min(north) == pytest.approx(8 * 40)


def test_scale_sets_the_drawing_size(problem: Problem, layout: Layout) -> None:
    small = ET.fromstring(render_svg(problem, layout, scale=10))
    large = ET.fromstring(render_svg(problem, layout, scale=40))
    assert float(large.get("width")) - float(small.get("width")) == pytest.approx(10 * 30)
    with pytest.raises(ValueError):
        render_svg(problem, layout, scale=0)


def test_doors_swing_into_their_room_windows_sit_in_walls_and_north_is_marked() -> None:
    from floorplan.models import Problem
    from floorplan.solver import solve

    problem = Problem.model_validate({
        "boundary": [[0, 0], [8, 0], [8, 5], [0, 5]], "entrance": [2, 0],
        "rooms": [{"id": "living", "type": "living", "min_size": [3, 3]},
                  {"id": "bed", "type": "bedroom", "min_size": [3, 3]}],
        "adjacency": [{"a": "living", "b": "bed"}], "options": {"time_limit": 2},
    })
    layout: Layout = solve(problem)
    assert layout.doors and layout.windows
    root = ET.fromstring(render_svg(problem, layout))
    ns = {"svg": "http://www.w3.org/2000/svg"}
    swings = root.findall(".//svg:path[@class='door-swing']", ns)
    assert len(swings) == len(layout.doors)
    assert all(" A " in s.get("d", "") for s in swings)  # an arc
    assert len(root.findall(".//svg:line[@class='window-pane']", ns)) == len(layout.windows)
    arrow = root.find(".//svg:g[@class='north-arrow']", ns)
    assert arrow is not None and "N" in "".join(arrow.itertext())
    assert arrow.get("transform") is None  # north up: the problem's y grows north
    # True north along the plan's +x (`north: 90`): the arrow turned a quarter clockwise.
    turned = ET.fromstring(render_svg(problem.model_copy(update={"north": 90.0}), layout))
    arrow = turned.find(".//svg:g[@class='north-arrow']", ns)
    assert arrow is not None and (arrow.get("transform") or "").startswith("rotate(90 ")


def test_partitions_are_drawn_once_with_thickness_and_the_facade_thicker(svg: ET.Element) -> None:
    walls = svg.findall(".//svg:path[@class='interior-walls']", NS)
    assert len(walls) == 1
    outline = svg.find(".//svg:path[@class='outline']", NS)
    assert outline is not None
    assert float(walls[0].get("stroke-width", 0)) < float(outline.get("stroke-width", 0))
    # At 40 units a metre: the x = 6 wall between living and bedroom (y 0..4 -> page y
    # 412..252 with the frame's margins) and the room edges along the gap, none on the
    # outline, whose x = 0 and x = 10 sides are at page x 24 and 424.
    d = walls[0].get("d", "")
    xs = {float(pair.split(",")[0]) for pair in re.findall(r"[\d.]+,[\d.]+", d)}
    assert 24 + 6 * 40 in xs
    segments = [s.strip() for s in d.split("M ") if s.strip()]
    assert not any(all(float(p.split(",")[0]) in (24, 424) for p in s.split(" L "))
                   for s in segments)
