"""Doors, windows and circulation on hand-made layouts (no solver needed)."""

from __future__ import annotations

from typing import Any

import pytest
from shapely.geometry import LineString, Point, Polygon, box

from floorplan.models import OUTSIDE, Problem
from floorplan.solver.openings import (
    FACADE_THICKNESS,
    MAX_WINDOWS_PER_WALL,
    add_openings,
    connection_demands,
    place_windows,
    walk,
)

#   +----------+------+
#   |  bed     | bath |   y 4..8
#   +----+-----+------+
#   |hall| living     |   y 0..4, entrance at (6, 0)
#   +----+------------+
#   0    2     6      8 (bath from x 6)
ROOMS = {
    "hall": box(0, 0, 2, 4),
    "living": box(2, 0, 8, 4),
    "bed": box(0, 4, 6, 8),
    "bath": box(6, 4, 8, 8),
}
TYPES = {"hall": "corridor", "living": "living", "bed": "bedroom", "bath": "bathroom"}


def problem(**fields: Any) -> Problem:
    data: dict[str, Any] = {
        "boundary": [[0, 0], [8, 0], [8, 8], [0, 8]],
        "entrance": [6, 0],
        "rooms": [{"id": k, "type": t} for k, t in TYPES.items()],
        "adjacency": [{"a": "living", "b": "hall"}, {"a": "hall", "b": "bed"},
                      {"a": "bed", "b": "bath"}],
    }
    data.update(fields)
    return Problem.model_validate(data)


def doors_between(p: Problem) -> dict[frozenset[str], Any]:
    return {frozenset(d.between): d for d in add_openings(p, ROOMS).doors}


def test_a_door_sits_centred_on_the_shared_wall_of_each_adjacent_pair() -> None:
    doors = doors_between(problem())
    door = doors[frozenset({"hall", "bed"})]
    (x0, y0), (x1, y1) = door.segment
    assert y0 == y1 == 4  # in the wall between them
    assert abs(x1 - x0) == pytest.approx(0.9)
    assert (x0 + x1) / 2 == pytest.approx(1.0)  # the middle of the 2 m shared wall
    assert door.requested


def test_the_front_door_is_where_the_entrance_is() -> None:
    doors = doors_between(problem())
    front = doors[frozenset({OUTSIDE, "living"})]
    (x0, y0), (x1, y1) = front.segment
    assert y0 == y1 == 0 and x0 < 6 < x1
    assert front.opens_into == "living"


def test_the_door_policy_keeps_a_bathroom_off_a_kitchen_unless_overridden() -> None:
    kitchen = problem(rooms=[{"id": k, "type": "kitchen" if k == "bed" else t}
                             for k, t in TYPES.items()],
                      adjacency=[{"a": "bed", "b": "bath"}])
    assert frozenset({"bed", "bath"}) not in doors_between(kitchen)  # bathroom-kitchen
    custom = problem(openings={"door_policy": {}},
                     rooms=[{"id": k, "type": "kitchen" if k == "bed" else t}
                            for k, t in TYPES.items()],
                     adjacency=[{"a": "bed", "b": "bath"}])
    assert frozenset({"bed", "bath"}) in doors_between(custom)


def test_windows_go_on_exterior_walls_only_and_not_in_windowless_rooms() -> None:
    openings = add_openings(problem(openings={"windowless": ["bathroom"]}), ROOMS)
    by_room: dict[str, list[LineString]] = {}
    for w in openings.windows:
        by_room.setdefault(w.room, []).append(LineString(w.segment))
    assert "bath" not in by_room
    outline = Polygon([(0, 0), (8, 0), (8, 8), (0, 8)]).exterior
    for lines in by_room.values():
        for line in lines:
            assert line.length == pytest.approx(1.2)
            assert outline.distance(line) < 1e-9 and line.difference(outline).length < 1e-9
    # The bedroom has 6 m of north wall and 4 m of west wall: two windows, then one.
    assert len(by_room["bed"]) == 3
    front = next(d for d in openings.doors if OUTSIDE in d.between)
    assert all(line.distance(LineString(front.segment)) > 0 for line in by_room["living"])


def test_circulation_counts_door_steps_and_finds_dead_ends() -> None:
    circulation = add_openings(problem(), ROOMS).circulation
    assert circulation is not None and circulation.reachable
    assert circulation.steps == {"living": 1, "hall": 2, "bed": 3, "bath": 4}
    assert circulation.furthest == 4
    assert circulation.dead_ends == ["bath"]


def test_a_room_behind_a_bathroom_is_unreachable() -> None:
    p = problem(adjacency=[{"a": "living", "b": "bath"}, {"a": "bath", "b": "bed"}],
                openings={"door_policy": {}})
    rooms = dict(ROOMS)
    rooms["living"] = box(2, 0, 8, 4)
    openings = add_openings(p, rooms)
    assert openings.circulation is not None
    assert "bed" in openings.circulation.unreachable  # only through the bathroom
    assert "hall" in openings.circulation.unreachable  # no door at all


def test_require_connected_adds_the_missing_doors() -> None:
    p = problem(adjacency=[], options={"require_connected": True})
    openings = add_openings(p, ROOMS)
    assert openings.circulation is not None and openings.circulation.reachable
    added = [d for d in openings.doors if not d.requested]
    assert added and all(OUTSIDE not in d.between for d in added)
    assert walk(p, openings.doors).reachable


def test_without_an_entrance_there_is_no_circulation_report() -> None:
    assert add_openings(problem(entrance=None), ROOMS).circulation is None


def test_connection_demands_link_every_room_to_the_front_door_room() -> None:
    # living-hall is asked for; bed and bath are not linked to anything passable.
    p = problem(adjacency=[{"a": "living", "b": "hall"}, {"a": "bed", "b": "bath"}],
                options={"require_connected": True})
    strict = problem(adjacency=[{"a": "living", "b": "hall"}, {"a": "bed", "b": "bath"}],
                     options={"require_connected": True},
                     openings={"door_policy": {"bathroom": ["corridor"]}})
    # Allowed onto corridors only, the bathroom needs its own door to the hall.
    assert [(a.a, a.partners) for a in connection_demands(strict).adjacency[2:]] == [
        ("bed", ["hall", "living"]), ("bath", ["hall"])]
    demanded = connection_demands(p)
    added = demanded.adjacency[len(p.adjacency):]
    # The bedroom must open onto the hall or the living room; the bathroom is then
    # reached through it (the default policy lets a bathroom open onto a bedroom).
    assert {a.a: sorted(a.partners) for a in added} == {"bed": ["hall", "living"]}
    assert all(a.min_contact >= p.openings.door_width for a in added)
    # No foyer: the corridor receives the front door, at the entrance point.
    hall = demanded.room("hall")
    assert hall.positions and abs(hall.positions[-1][0] - 6) < 1e-9


def test_connection_demands_leave_a_linked_problem_alone() -> None:
    # bed touches one of two linked rooms: linked whichever it is.
    p = problem(adjacency=[{"a": "living", "b": "hall"}, {"a": "bed", "any_of": ["hall", "living"]},
                           {"a": "bath", "b": "hall"}],
                options={"require_connected": True},
                rooms=[{"id": k, "type": t, **({"positions": [[6, 0.05]]} if k == "hall" else {})}
                       for k, t in TYPES.items()])
    demanded = connection_demands(p)
    assert demanded.adjacency == p.adjacency
    assert demanded.rooms == p.rooms
    # Without the option nothing changes at all.
    loose = problem(adjacency=[])
    assert connection_demands(loose) is loose


def test_a_wall_kilometres_long_gets_a_bounded_number_of_windows() -> None:
    # A 200 km square of two rooms once made 266,663 windows and a 20 MB result.
    side = 1e4
    p = Problem.model_validate({
        "boundary": [[0, 0], [side, 0], [side, side], [0, side]],
        "rooms": [{"id": "a", "type": "bedroom"}, {"id": "b", "type": "bedroom"}]})
    rooms = {"a": box(0, 0, side / 2, side), "b": box(side / 2, 0, side, side)}
    windows = place_windows(p, rooms, [])
    # Each room has three exterior walls.
    assert 0 < len(windows) <= 2 * 3 * MAX_WINDOWS_PER_WALL
    assert all(w.room in rooms for w in windows)


def test_windows_keep_the_facades_thickness_from_an_inner_corner() -> None:
    # An L outline, inner corner (4, 4). The dining room's wall y = 4 runs from the
    # corner to x = 5.5: 1.5 m, a window's 1.2 m and clearance, but its first 0.25 m is
    # the end of the facade wall x = 4 (the exports build it outside the outline).
    p = Problem.model_validate({
        "boundary": [[0, 0], [8, 0], [8, 4], [4, 4], [4, 8], [0, 8]],
        "rooms": [{"id": "dining", "type": "dining"}, {"id": "bed", "type": "bedroom"},
                  {"id": "west", "type": "living"}]})
    rooms = {"dining": box(4, 0, 5.5, 4), "bed": box(5.5, 0, 8, 4), "west": box(0, 0, 4, 8)}
    windows = place_windows(p, rooms, [])
    corner = Point(4, 4)
    assert all(LineString(w.segment).distance(corner) >= FACADE_THICKNESS - 1e-9
               for w in windows)
    # The wall beside it keeps its window: only the corner's end is cut.
    assert any(w.room == "bed" and w.segment[0][1] == 4 for w in windows)
    assert not any(w.room == "dining" and w.segment[0][1] == 4 for w in windows)


def test_no_window_on_a_sliver_of_a_room_along_the_facade() -> None:
    # The bath stops 1 cm short of the north facade and the bed takes that 1 cm strip
    # above it (as gap absorption can leave one): the bed's windows stay on its own
    # 6 m of north wall, none on the strip, whose depth is all interior wall.
    rooms = {**ROOMS, "bed": box(0, 4, 6, 8).union(box(6, 7.99, 8, 8)),
             "bath": box(6, 4, 8, 7.99)}
    windows = [LineString(w.segment) for w in add_openings(problem(), rooms).windows
               if w.room == "bed"]
    assert windows
    assert all(line.bounds[2] <= 6 + 1e-9 for line in windows)
