"""Several storeys (paper Fig. 11): floors with their own rooms, vertical rooms on the
same footprint on every floor they span. Real SCIP, small time limits; the footprints
are compared with shapely on the returned polygons, not with the solver's own alignment
check."""

from __future__ import annotations

import copy
import json
import time
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from typing import Any

import httpx2 as httpx
import pytest
import shapely
from pydantic import ValidationError

from floorplan.models import Layout, Problem, Termination
from floorplan.solver import solve
from floorplan.solver.events import Phase, SolveEvent
from floorplan.solver.export.dxf import to_dxf
from floorplan.solver.export.geojson import to_geojson
from floorplan.solver.export.svg import render_svg
from tests.paths import EXAMPLES
from tests.servers import Server

HOUSE = json.loads((EXAMPLES / "two-storey-house.json").read_text())


def house(**options: Any) -> dict[str, Any]:
    data = copy.deepcopy(HOUSE)
    data["options"] = {"time_limit": 6, **options}
    return data


def footprint(layout: Layout, floor_id: str, room_id: str) -> shapely.Polygon:
    floor = next(f for f in layout.floors or [] if f.id == floor_id)
    room = next(r for r in floor.rooms if r.id == room_id)
    return shapely.Polygon(room.polygon)


def office_block() -> dict[str, Any]:
    """Three floors of offices: a lift through all three, stairs through the first two."""
    def floor(k: int, halls: list[str]) -> dict[str, Any]:
        return {
            "id": f"f{k}",
            "rooms": [
                {"id": "hall", "type": "corridor", "min_size": [1.2, 1.2]},
                {"id": f"office-{k}a", "type": "office", "min_size": [2.5, 2.5],
                 "target_size": [4, 3]},
                {"id": f"office-{k}b", "type": "office", "min_size": [2.5, 2.5],
                 "target_size": [4, 3]},
            ],
            "adjacency": [{"a": "hall", "b": other} for other in halls],
        }

    return {
        "name": "office block",
        "boundary": [[0, 0], [9, 0], [9, 6], [0, 6]],
        "floors": [floor(1, ["lift", "stairs"]), floor(2, ["lift", "stairs"]),
                   floor(3, ["lift"])],
        "vertical": [
            {"id": "lift", "type": "lift", "min_size": [1.5, 1.5], "max_size": [2, 2]},
            {"id": "stairs", "type": "stairs", "floors": ["f1", "f2"],
             "min_size": [1.0, 2.5], "max_size": [1.3, 3.0]},
        ],
        "options": {"time_limit": 8},
    }


# -- solving --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def solved_house() -> tuple[Problem, Layout, list[SolveEvent]]:
    # Each floor ends at its first good layout (valid, 99 % covered): a limit of 6 s
    # left a busy machine without one.
    problem = Problem.model_validate(house(time_limit=60, stop_when_good=True))
    events: list[SolveEvent] = []
    layout = solve(problem, on_event=events.append)
    return problem, layout, events


def test_two_storey_house_is_valid_with_the_stairs_on_one_footprint(
    solved_house: tuple[Problem, Layout, list[SolveEvent]],
) -> None:
    _, layout, _ = solved_house
    assert layout.floors is not None and [f.id for f in layout.floors] == ["ground", "upper"]
    assert layout.rooms == [] and layout.doors == [] and layout.windows == []
    assert layout.report.valid, [c for c in layout.report.constraints if not c.satisfied]
    for floor in layout.floors:
        assert floor.report.valid
        assert floor.report.coverage >= 0.99, (floor.id, floor.report.coverage)
        assert {r.id for r in floor.rooms} >= {"stairs"}
    ground, upper = footprint(layout, "ground", "stairs"), footprint(layout, "upper", "stairs")
    assert ground.area >= 1.0 * 2.5 - 1e-6
    assert ground.symmetric_difference(upper).area < 1e-9
    assert ground.equals(upper)
    vertical = [c for c in layout.report.constraints if c.kind == "vertical"]
    assert [(c.rooms, c.satisfied) for c in vertical] == [(["stairs"], True)]
    # Every floor's checks are carried with the floor's id.
    floors_named = {c.floor for c in layout.report.constraints if c.kind != "vertical"}
    assert floors_named == {"ground", "upper"}


def test_adjacencies_to_the_stairs_hold_on_both_floors(
    solved_house: tuple[Problem, Layout, list[SolveEvent]],
) -> None:
    _, layout, _ = solved_house
    for floor_id, neighbour in (("ground", "foyer"), ("upper", "landing")):
        stairs = footprint(layout, floor_id, "stairs")
        other = footprint(layout, floor_id, neighbour)
        assert stairs.intersection(other).length >= 0.9 - 1e-4, floor_id


def test_building_report_sums_up_the_floors(
    solved_house: tuple[Problem, Layout, list[SolveEvent]],
) -> None:
    _, layout, _ = solved_house
    assert layout.floors is not None
    assert layout.report.coverage == pytest.approx(
        sum(f.report.coverage for f in layout.floors) / 2)  # equal floor areas
    assert layout.report.termination in (Termination.OPTIMAL, Termination.STALLED,
                                         Termination.INTERRUPTED)
    assert set(layout.report.size_error) >= {"ground/living", "upper/bed-1"}
    assert len(layout.all_rooms) == 6 + 6
    assert Layout.model_validate_json(layout.model_dump_json()) == layout


def test_events_name_the_floor_being_solved(
    solved_house: tuple[Problem, Layout, list[SolveEvent]],
) -> None:
    _, _, events = solved_house
    floors_seen = [e.floor for e in events if e.phase is Phase.LEVEL]
    assert "ground" in floors_seen and "upper" in floors_seen
    assert all(e.detail.startswith(f"floor {e.floor}") for e in events)
    elapsed = [e.elapsed for e in events]
    assert elapsed == sorted(elapsed)  # one clock for the whole building


def test_outputs_draw_every_floor(
    solved_house: tuple[Problem, Layout, list[SolveEvent]],
) -> None:
    problem, layout, _ = solved_house
    svg = ET.fromstring(render_svg(problem, layout))
    ns = {"svg": "http://www.w3.org/2000/svg"}
    plans = svg.findall("svg:svg", ns)
    assert [p.get("data-floor") for p in plans] == ["ground", "upper"]
    titles = [p.find("svg:text[@class='title']", ns) for p in plans]
    assert [t.text for t in titles if t is not None] == [
        "two-storey house - ground floor", "two-storey house - upper floor"]
    ids = [e.get("id") for e in svg.iter() if e.get("id")]
    assert len(ids) == len(set(ids))
    geo = to_geojson(problem, layout)
    rooms = [f["properties"] for f in geo["features"] if f["properties"]["kind"] == "room"]
    assert sorted((r["floor"], r["id"]) for r in rooms if r["id"] == "stairs") == [
        ("ground", "stairs"), ("upper", "stairs")]
    dxf = to_dxf(problem, layout, layers="room-type").decode()
    assert "GROUND-ROOM_STAIRS" in dxf and "UPPER-ROOM_BEDROOM" in dxf


@pytest.mark.slow
def test_three_floors_with_a_lift_through_all_and_stairs_through_two() -> None:
    problem = Problem.model_validate(office_block())
    layout = solve(problem)
    assert layout.floors is not None and len(layout.floors) == 3
    assert layout.report.valid, [c for c in layout.report.constraints if not c.satisfied]
    lifts = [footprint(layout, f, "lift") for f in ("f1", "f2", "f3")]
    assert all(lift.equals(lifts[0]) for lift in lifts)
    assert footprint(layout, "f1", "stairs").equals(footprint(layout, "f2", "stairs"))
    f3 = next(f for f in layout.floors if f.id == "f3")
    assert "stairs" not in {r.id for r in f3.rooms}
    assert {c.rooms[0] for c in layout.report.constraints if c.kind == "vertical"} == {
        "lift", "stairs"}


@pytest.mark.slow
def test_a_footprint_no_other_floor_can_take_fails_naming_the_floor() -> None:
    """The upper floor covers only the west 6 m; the ground floor's foyer, which the
    stairs must touch, is held at the east end: no anchor can satisfy both floors."""
    data = {
        "name": "impossible stairs",
        "boundary": [[0, 0], [10, 0], [10, 6], [0, 6]],
        "floors": [
            {"id": "ground", "rooms": [
                {"id": "foyer", "min_size": [1.5, 1.5], "max_size": [2, 2],
                 "positions": [[9.5, 0.5]]},
                {"id": "hall", "min_size": [1, 1]}],
             "adjacency": [{"a": "foyer", "b": "stairs", "min_contact": 1.0}]},
            {"id": "upper", "boundary": [[0, 0], [6, 0], [6, 6], [0, 6]],
             "rooms": [{"id": "room", "min_size": [1, 1]}]},
        ],
        "vertical": [{"id": "stairs", "min_size": [1, 2.5], "max_size": [1.2, 3]}],
        "options": {"time_limit": 4},
    }
    layout = solve(Problem.model_validate(data))
    assert layout.floors is None and layout.all_rooms == []
    assert layout.report.termination in (Termination.NO_SOLUTION, Termination.INFEASIBLE)
    why = layout.report.infeasibility
    assert why is not None
    assert why.reason.startswith("floor '")
    anchors = [r for r in why.relaxations_tried if r.startswith("anchored on floor")]
    assert anchors and any("'upper'" in r or "'ground'" in r for r in anchors)


def test_stop_request_ends_a_building_solve() -> None:
    # Asked to stop at the first incumbent: the solve ends interrupted, and no floor
    # after the one it was solving is started (each would run to the 30 s limit).
    events: list[SolveEvent] = []
    stopped_in: list[str] = []

    def on_event(event: SolveEvent) -> None:
        events.append(event)
        if event.phase is Phase.INCUMBENT and not stopped_in:
            stopped_in.append(event.floor)

    layout = solve(Problem.model_validate(house(time_limit=30)), on_event=on_event,
                   should_stop=lambda: bool(stopped_in))
    assert layout.report.termination is Termination.INTERRUPTED
    assert stopped_in, "no incumbent"
    after = events[next(k for k, e in enumerate(events) if e.phase is Phase.INCUMBENT):]
    assert {e.floor for e in after if e.phase is Phase.LEVEL} <= set(stopped_in)


# -- validation -----------------------------------------------------------------------


def error_locs(data: dict[str, Any]) -> set[str]:
    with pytest.raises(ValidationError) as info:
        Problem.model_validate(data)
    return {".".join(str(p) for p in e["loc"]) for e in info.value.errors()}


def test_the_same_room_id_may_be_used_on_two_floors() -> None:
    data = house()
    data["floors"][1]["rooms"].append({"id": "wc", "type": "wc", "min_size": [1, 1.2]})
    Problem.model_validate(data)


@pytest.mark.parametrize(("change", "field"), [
    (lambda d: d.update(rooms=[{"id": "x"}]), "rooms"),
    (lambda d: d.update(adjacency=[{"a": "foyer", "b": "stairs"}]), "adjacency"),
    (lambda d: d["vertical"][0].update(floors=["ground", "attic"]), "vertical.0.floors.1"),
    (lambda d: d["vertical"][0].update(floors=["ground"]), "vertical.0.floors"),
    (lambda d: d["floors"][1].update(id="ground"), "floors.1.id"),
    (lambda d: d["floors"][1]["adjacency"].append({"a": "landing", "b": "kitchen"}),
     "floors.1.adjacency.5.b"),
    (lambda d: d["floors"][0]["rooms"][0].update(positions=[[20, 1]]),
     "floors.0.rooms.0.positions.0"),
    (lambda d: d["floors"][1].update(boundary=[[0, 0], [5, 1], [5, 8], [0, 8]]),
     "floors.1.boundary.0"),
    (lambda d: d["vertical"][0].update(positions=[[9, 7]]) or d["floors"][1].update(
        boundary=[[0, 0], [6, 0], [6, 8], [0, 8]]), "vertical.0.positions.0"),
    (lambda d: d["vertical"][0].update(min_size=[1.0, 9.0], max_size=[1.3, 9.0]),
     "vertical.0.min_size"),
    (lambda d: d["floors"][0]["rooms"].append({"id": "stairs"}), "vertical.0.id"),
    (lambda d: d["vertical"].append(dict(d["vertical"][0])), "vertical.1.id"),
])
def test_bad_building_is_refused_naming_the_field(change: Any, field: str) -> None:
    data = house()
    change(data)
    assert field in error_locs(data)


def test_a_vertical_room_must_fit_the_floors_it_spans_together() -> None:
    """Each floor leaves room for 3 m stairs, but not in the same place."""
    data = house()
    data["floors"][0]["obstacles"] = [{"x": 0, "y": 0, "width": 10, "depth": 5}]
    data["floors"][1]["obstacles"] = [{"x": 0, "y": 5, "width": 10, "depth": 3}]
    data["vertical"][0].update(min_size=[1.0, 2.6])
    for room in data["floors"][0]["rooms"] + data["floors"][1]["rooms"]:
        room.pop("positions", None)
        room.pop("boundary", None)
    assert "vertical.0.min_size" in error_locs(data)


def test_without_floors_rooms_stay_required_and_vertical_needs_floors() -> None:
    bare = {"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]]}
    assert error_locs(bare) == {"rooms"}
    assert error_locs({**bare, "rooms": []}) == {"rooms"}
    assert "vertical" in error_locs({**bare, "rooms": [{"id": "a"}],
                                     "vertical": [{"id": "s"}]})


def test_templated_problems_do_not_take_floors() -> None:
    data = {"boundary": [[0, 0], [9, 0], [9, 7], [0, 7]], "template": "residential",
            "rooms": ["living", "bedroom"], "floors": [{"id": "a"}]}
    assert "floors" in error_locs(data)


# -- the service ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    s = Server(tmp_path_factory.mktemp("storeys")).start()
    yield s
    s.stop()


@pytest.mark.slow
def test_service_round_trip_of_a_two_floor_problem(server: Server) -> None:
    with httpx.Client(base_url=server.url, timeout=30) as client:
        # Ended at its first good layout (a busy machine found none in a 5 s limit).
        posted = client.post("/v1/layouts", json=house(time_limit=60, stop_when_good=True))
        assert posted.status_code == 202, posted.text
        job_id = posted.json()["id"]
        deadline = time.monotonic() + 120
        while (job := client.get(f"/v1/layouts/{job_id}").json())["status"] not in (
                "succeeded", "failed", "canceled"):
            assert time.monotonic() < deadline, job
            time.sleep(0.2)
        assert job["status"] == "succeeded", job
        layout = Layout.model_validate(client.get(f"/v1/layouts/{job_id}/result").json())
        assert layout.floors is not None and len(layout.floors) == 2
        assert footprint(layout, "ground", "stairs").equals(footprint(layout, "upper", "stairs"))
        svg = client.get(f"/v1/layouts/{job_id}/result", params={"format": "svg"})
        assert svg.status_code == 200 and 'data-floor="upper"' in svg.text
        refused = client.post("/v1/layouts", json={**house(), "rooms": [{"id": "x"}]})
        assert refused.status_code == 422
        assert "rooms" in {e["field"] for e in refused.json()["errors"]}
