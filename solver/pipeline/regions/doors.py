"""Large layouts, step 5: doors onto the aisles, from the entrance and between rooms,
and the walk from the entrance through the aisles."""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping, Sequence

import shapely
from shapely.geometry import LineString, Polygon

from floorplan.models import (
    OUTSIDE,
    Circulation,
    Door,
    Problem,
)
from floorplan.solver.geometry import longest_shared_wall
from floorplan.solver.openings import door_segment as _door_segment
from floorplan.solver.openings import front_door, may_connect
from floorplan.solver.pipeline.regions.partition import rooms_only


def aisle_doors(problem: Problem, rooms: Mapping[str, Polygon],
                aisles: Mapping[str, Polygon]) -> list[Door]:
    """A door from each room onto the aisle it shares the longest wall with."""
    doors = []
    width = problem.openings.door_width
    for room_id, polygon in rooms.items():
        walls = [(wall, a) for a, shape in aisles.items()
                 if (wall := longest_shared_wall(polygon, shape)) is not None]
        if not walls:
            continue
        wall, aisle = max(walls, key=lambda w: w[0].length)
        segment = _door_segment(wall, width)
        if segment is not None:
            doors.append(Door(between=(aisle, room_id), segment=segment, opens_into=room_id,
                              requested=False))
    return doors


def entrance_door(problem: Problem, rooms: Mapping[str, Polygon],
                  aisles: Mapping[str, Polygon]) -> Door | None:
    """The front door, into the aisle at the entrance (else into the room there)."""
    return front_door(problem, aisles) or front_door(rooms_only(problem), rooms)


def through_doors(problem: Problem, rooms: Mapping[str, Polygon],
                  aisles: Mapping[str, Polygon], doors: list[Door]) -> list[Door]:
    """A room touching no aisle gets a door onto the neighbour with the longest wall
    that is already reached from an aisle (the door policy allowing)."""
    added: list[Door] = []
    width = problem.openings.door_width
    ends = {r.id for r in problem.rooms if r.type in problem.openings.no_passage}
    reached = set(_steps(problem, doors, aisles, from_aisles=True))
    names = list(rooms)
    tree = shapely.STRtree([rooms[n] for n in names])
    walls: dict[str, list[tuple[float, str, LineString]]] = {}
    for room_id in names:
        if room_id in reached:
            continue
        for j in tree.query(rooms[room_id], "touches"):
            other = names[int(j)]
            if other == room_id or not may_connect(problem, room_id, other):
                continue
            wall = longest_shared_wall(rooms[room_id], rooms[other])
            if wall is not None and wall.length >= width - 1e-4:
                walls.setdefault(room_id, []).append((wall.length, other, wall))
    while True:
        options = [(length, room_id, other, wall) for room_id, found in walls.items()
                   if room_id not in reached for length, other, wall in found
                   if other in reached and other not in ends]
        if not options:
            return added
        _, room_id, other, wall = max(options, key=lambda o: o[0])
        segment = _door_segment(wall, width)
        assert segment is not None
        added.append(Door(between=(other, room_id), segment=segment, opens_into=room_id,
                          requested=False))
        reached.add(room_id)


def _steps(problem: Problem, doors: Sequence[Door], aisles: Mapping[str, Polygon], *,
           from_aisles: bool = False) -> dict[str, int]:
    """Doors passed from outside (or from any aisle) to each place; moving between two
    aisles that meet passes no door. Never through an end room (a bathroom)."""
    links: dict[str, set[str]] = {}
    for door in doors:
        a, b = door.between
        links.setdefault(a, set()).add(b)
        links.setdefault(b, set()).add(a)
    ends = {r.id for r in problem.rooms if r.type in problem.openings.no_passage}
    names = list(aisles)
    free: dict[str, set[str]] = {a: set() for a in names}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if aisles[a].intersection(aisles[b]).length > 1e-3:
                free[a].add(b)
                free[b].add(a)
    outline = problem.outline().exterior
    if from_aisles:
        starts = names
    elif problem.entrance is not None:
        starts = [OUTSIDE]
    else:  # the aisles' facade ends are the exits
        starts = [OUTSIDE]
        for a in names:
            if aisles[a].exterior.intersection(outline).length > 1e-3:
                free.setdefault(OUTSIDE, set()).add(a)
    steps = dict.fromkeys(starts, 0)
    queue = deque(starts)
    while queue:
        here = queue.popleft()
        if here in ends:
            continue
        for there in sorted(free.get(here, set())):
            if there not in steps or steps[there] > steps[here]:
                steps[there] = steps[here]
                queue.appendleft(there)
        for there in sorted(links.get(here, set())):
            if there not in steps:
                steps[there] = steps[here] + 1
                queue.append(there)
    return steps


def walk_aisles(problem: Problem, doors: Sequence[Door],
                aisles: Mapping[str, Polygon]) -> Circulation:
    """The circulation report, walked from outside through the aisles and doors."""
    steps = _steps(problem, doors, aisles)
    room_steps = {r.id: steps[r.id] for r in problem.rooms if r.id in steps}
    unreachable = [r.id for r in problem.rooms if r.id not in steps]
    degree: dict[str, int] = {}
    for door in doors:
        for name in door.between:
            degree[name] = degree.get(name, 0) + 1
    dead_ends = [r.id for r in problem.rooms if degree.get(r.id, 0) == 1]
    return Circulation(reachable=not unreachable, unreachable=unreachable, steps=room_steps,
                       furthest=max(room_steps.values(), default=0), dead_ends=dead_ends)
