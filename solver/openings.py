"""Doors, windows and circulation on a finished layout (paper Sec. 5.4; circulation
after Peng et al.).

A door goes on the longest wall each adjacency-constrained pair shares, centred and
clear of the corners, when the door policy allows the two room types; the front door
goes where the entrance is. Windows are spread evenly over each room's exterior walls.
The doors make a graph, walked from outside, that says which rooms can be reached and
how many doors away they are.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass

from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.polygon import orient

from floorplan.models import OUTSIDE, Adjacency, Circulation, Door, Problem, Window
from floorplan.models.problem import inside_entrance
from floorplan.solver.geometry import longest_shared_wall, straight_stretches

#: A door keeps this far (metres) from the corners of the wall it is in.
CORNER_CLEARANCE = 0.1
#: Room types meant for walking through, preferred for doors added for reachability.
CIRCULATION_TYPES = frozenset({"corridor", "hall", "foyer", "living", "dining", "lobby"})
#: Lengths below this count as zero.
EPS = 1e-6
#: A wall this much shorter than a door still takes it: SCIP meets a minimum contact
#: only within its tolerance (the checker's).
WALL_TOLERANCE = 1e-4
#: The room types that receive the front door under `require_connected`, first found wins.
ENTRANCE_TYPES = ("foyer", "hall", "lobby", "corridor", "living")
#: How far inside the outline the front-door room's position point sits (metres).
ENTRANCE_INSET = 0.05
#: The facade's thickness (metres; the exports build it outside the outline). At an
#: inner corner of the outline the other facade wall's end stands this deep into the
#: wall beside it, so no window or front door goes there.
FACADE_THICKNESS = 0.25
#: A window lies only where its room is at least this deep behind the facade (metres):
#: a sliver of a room along the facade (gap absorption may leave one a centimetre deep)
#: has an interior wall in its depth, and a window there would open onto that wall.
WINDOW_MIN_DEPTH = 0.3
#: Windows on one straight exterior wall at most: a facade of 64 windows (some 190 m at
#: the default spacing) is already more than any room of a building has.
MAX_WINDOWS_PER_WALL = 64


@dataclass(frozen=True)
class Openings:
    doors: list[Door]
    windows: list[Window]
    circulation: Circulation | None


def add_openings(problem: Problem, rooms: Mapping[str, Polygon]) -> Openings:
    """Doors, windows and the circulation report of a layout."""
    doors = requested_doors(problem, rooms)
    front = front_door(problem, rooms)
    if front is not None:
        doors.append(front)
    if problem.options.require_connected and front is not None:
        doors += connecting_doors(problem, rooms, doors)
    windows = place_windows(problem, rooms, doors)
    circulation = walk(problem, doors) if front is not None else None
    return Openings(doors, windows, circulation)


def connection_demands(problem: Problem) -> Problem:
    """`require_connected` in the MIQP, through the adjacency choices: the problem
    with the constraints that make every layout satisfying them connected.

    A door needs a wall of at least a door's width; the user's adjacencies that the
    door policy allows are the links already demanded. Every room left outside the
    part linked to the front-door room gets an `any_of` adjacency (Eq. 11) to the
    rooms of that part it may open onto, preferring corridors and living spaces;
    the front-door room gets the entrance as a position (Eq. 8) when no room has it.
    """
    if not problem.options.require_connected or problem.entrance is None:
        return problem
    ends = {r.id for r in problem.rooms if r.type in problem.openings.no_passage}
    passable = [r.id for r in problem.rooms if r.id not in ends]
    entry = _entrance_room(problem, passable)
    if entry is None:
        return problem
    contact = problem.openings.door_width + 2 * CORNER_CLEARANCE
    links: dict[str, set[str]] = {r.id: set() for r in problem.rooms}
    for adj in problem.adjacency:
        if adj.b is not None and adj.min_contact >= problem.openings.door_width - EPS \
                and may_connect(problem, adj.a, adj.b):
            links[adj.a].add(adj.b)
            links[adj.b].add(adj.a)
    demands: list[Adjacency] = []
    reached = _linked(entry, links, ends)
    # An `any_of` adjacency links its room in once every partner is linked in.
    choices = [adj for adj in problem.adjacency if adj.any_of is not None]
    while joined := [adj for adj in choices if adj.a not in reached
                     and all(p in reached and p not in ends and may_connect(problem, adj.a, p)
                             for p in adj.partners)
                     and adj.min_contact >= problem.openings.door_width - EPS]:
        for adj in joined:
            links[adj.a].add(adj.partners[0])
            links[adj.partners[0]].add(adj.a)
        reached = _linked(entry, links, ends)
    # Passable rooms first, so that the ends can open onto the rooms they bring in.
    for room_id in sorted(set(links) - reached, key=lambda r: (r in ends, _order(problem, r))):
        if room_id in reached:
            continue
        partners = [p for p in passable if p in reached and may_connect(problem, room_id, p)]
        circulation = [p for p in partners if problem.room(p).type in CIRCULATION_TYPES]
        if not partners:
            continue
        demands.append(Adjacency(a=room_id, any_of=circulation or partners,
                                 min_contact=contact, soft=not problem.options.strict))
        # Any one of the partners links the room in; count it as reached from here on.
        links[room_id].add(partners[0])
        links[partners[0]].add(room_id)
        reached = _linked(entry, links, ends) | {room_id}
    rooms = problem.rooms
    if not any(_covers(room.positions, problem.entrance) for room in rooms):
        point = inside_entrance(problem.boundary, problem.entrance, problem.free_area(),
                                ENTRANCE_INSET)
        rooms = [r.model_copy(update={"positions": [*r.positions, point]})
                 if r.id == entry and len(r.positions) < 2 and point is not None else r
                 for r in rooms]
    return problem.model_copy(update={"adjacency": [*problem.adjacency, *demands],
                                      "rooms": rooms})


def _entrance_room(problem: Problem, passable: list[str]) -> str | None:
    for kind in ENTRANCE_TYPES:
        for room_id in passable:
            if problem.room(room_id).type == kind:
                return room_id
    return passable[0] if passable else None


def _order(problem: Problem, room_id: str) -> int:
    return [r.id for r in problem.rooms].index(room_id)


def _linked(start: str, links: Mapping[str, set[str]], ends: set[str]) -> set[str]:
    """The rooms linked to `start` (a passable room), never through an end room."""
    return set(door_steps(start, links, ends))


def _covers(points: list[tuple[float, float]], target: tuple[float, float]) -> bool:
    return any(Point(p).distance(Point(target)) <= 2 * ENTRANCE_INSET for p in points)


def may_connect(problem: Problem, a: str, b: str) -> bool:
    """Whether the door policy lets rooms `a` and `b` share a door (both ways)."""
    return problem.openings.allows_door(problem.room(a).type, problem.room(b).type)


def requested_doors(problem: Problem, rooms: Mapping[str, Polygon]) -> list[Door]:
    """One door per adjacency constraint: with `any_of`, to the partner sharing the
    longest wall among those the policy allows."""
    doors = []
    width = problem.openings.door_width
    for adj in problem.adjacency:
        if adj.a not in rooms:
            continue
        options = [(longest_shared_wall(rooms[adj.a], rooms[b]), b) for b in adj.partners
                   if b in rooms and b != adj.a and may_connect(problem, adj.a, b)]
        options = [(wall, b) for wall, b in options if wall is not None]
        if not options:
            continue
        wall, partner = max(options, key=lambda option: option[0].length)
        segment = door_segment(wall, width)
        if segment is not None:
            doors.append(Door(between=(adj.a, partner), segment=segment,
                              opens_into=_larger(rooms, adj.a, partner)))
    return doors


def front_door(problem: Problem, rooms: Mapping[str, Polygon]) -> Door | None:
    """The front door: in the outline where the entrance point is, into the room whose
    wall it lies on."""
    if problem.entrance is None:
        return None
    entrance = Point(problem.entrance)
    outline = problem.outline().exterior
    for room_id, polygon in rooms.items():
        walls = polygon.exterior.intersection(outline)
        if walls.is_empty or walls.distance(entrance) > 1e-3:
            continue
        wall = min(straight_stretches(walls), key=lambda s: s.distance(entrance))
        clear = clear_of_corners(wall, inner_corners(problem.outline()))
        segment = None if clear is None else door_segment(
            clear, problem.openings.door_width, centre=entrance)
        if segment is not None:
            return Door(between=(OUTSIDE, room_id), segment=segment, opens_into=room_id)
    return None


def connecting_doors(
    problem: Problem, rooms: Mapping[str, Polygon], doors: list[Door]
) -> list[Door]:
    """Extra doors for `require_connected`: while some room is unreachable, open it
    onto the reachable neighbour with the longest shared wall the policy allows."""
    added: list[Door] = []
    width = problem.openings.door_width
    while True:
        reached = set(walk(problem, doors + added).steps)
        ends = {r.id for r in problem.rooms if r.type in problem.openings.no_passage}
        best: tuple[tuple[bool, float], str, str, LineString] | None = None
        for room_id in rooms:
            if room_id in reached:
                continue
            for other in (reached - ends) & set(rooms):
                if not may_connect(problem, room_id, other):
                    continue
                wall = longest_shared_wall(rooms[room_id], rooms[other])
                if wall is None or wall.length < width - WALL_TOLERANCE:
                    continue
                # A door onto a corridor or living space beats a longer wall onto a
                # bedroom: nobody wants to cross a bedroom to get anywhere.
                score = (problem.room(other).type in CIRCULATION_TYPES, wall.length)
                if best is None or score > best[0]:
                    best = (score, room_id, other, wall)
        if best is None:
            return added
        _, room_id, other, wall = best
        segment = door_segment(wall, width)
        assert segment is not None
        added.append(Door(between=(other, room_id), segment=segment, opens_into=room_id,
                          requested=False))


def place_windows(
    problem: Problem, rooms: Mapping[str, Polygon], doors: list[Door]
) -> list[Window]:
    """Windows evenly spaced on each room's exterior walls, one per `window_spacing`
    metres but at most `MAX_WINDOWS_PER_WALL` on one wall (a 276-byte brief with a 200 km
    wall once made 266,663 windows; docs/security.md, "Not covered"), none where a door
    is."""
    openings = problem.openings
    outline = problem.outline().exterior
    inner = inner_corners(problem.outline())
    door_lines = [LineString(d.segment) for d in doors]
    windows = []
    for room_id, polygon in rooms.items():
        if problem.room(room_id).type in openings.windowless:
            continue
        # The room without its parts thinner than `WINDOW_MIN_DEPTH` (an opening: eroded,
        # then grown back; square corners keep a union of rectangles exact).
        half = WINDOW_MIN_DEPTH / 2
        deep = polygon.buffer(-half, join_style="mitre").buffer(half + EPS, join_style="mitre")
        walls = polygon.exterior.intersection(outline).intersection(deep)
        for stretch in straight_stretches(walls):
            wall = clear_of_corners(stretch, inner)
            if wall is None:
                continue
            count = min(int(wall.length // openings.window_spacing), MAX_WINDOWS_PER_WALL)
            if count == 0 and wall.length >= openings.window_width + 2 * CORNER_CLEARANCE:
                count = 1
            for k in range(count):
                centre = wall.interpolate((k + 0.5) * wall.length / count)
                segment = door_segment(wall, openings.window_width, centre=centre)
                if segment is None or any(
                    LineString(segment).distance(d) < CORNER_CLEARANCE for d in door_lines
                ):
                    continue
                windows.append(Window(room=room_id, segment=segment))
    return windows


def inner_corners(outline: Polygon) -> list[Point]:
    """The reflex corners of an outline (turning inwards), where two facade walls meet
    inside the building's bounding box.

    >>> [p.coords[0] for p in inner_corners(Polygon([(0, 0), (4, 0), (4, 2), (2, 2),
    ...                                              (2, 4), (0, 4)]))]
    [(2.0, 2.0)]
    """
    ring = list(orient(outline, 1.0).exterior.coords)[:-1]
    corners = []
    for k, (x, y) in enumerate(ring):
        (ax, ay), (bx, by) = ring[k - 1], ring[(k + 1) % len(ring)]
        if (x - ax) * (by - y) - (y - ay) * (bx - x) < -1e-12:  # a right turn on a CCW ring
            corners.append(Point(x, y))
    return corners


def clear_of_corners(wall: LineString, corners: list[Point]) -> LineString | None:
    """`wall` shortened by `FACADE_THICKNESS` at each end that is an inner corner of the
    outline; None when nothing is left."""
    (x0, y0), (x1, y1) = wall.coords[0], wall.coords[-1]
    length = wall.length
    start, end = 0.0, length
    for corner in corners:
        if corner.distance(Point(x0, y0)) < 1e-6:
            start = FACADE_THICKNESS
        if corner.distance(Point(x1, y1)) < 1e-6:
            end = length - FACADE_THICKNESS
    if end - start <= 1e-6:
        return None
    if (start, end) == (0.0, length):
        return wall
    return LineString([wall.interpolate(start).coords[0], wall.interpolate(end).coords[0]])


def walk(problem: Problem, doors: list[Door]) -> Circulation:
    """Breadth-first from outside through the doors, never through a room whose type
    is an end (`Openings.no_passage`)."""
    links: dict[str, set[str]] = {r.id: set() for r in problem.rooms} | {OUTSIDE: set()}
    for door in doors:
        a, b = door.between
        links[a].add(b)
        links[b].add(a)
    ends = {r.id for r in problem.rooms if r.type in problem.openings.no_passage}
    steps = door_steps(OUTSIDE, links, ends)
    del steps[OUTSIDE]
    unreachable = [r.id for r in problem.rooms if r.id not in steps]
    dead_ends = [r.id for r in problem.rooms if len(links[r.id]) == 1]
    return Circulation(reachable=not unreachable, unreachable=unreachable, steps=steps,
                       furthest=max(steps.values(), default=0), dead_ends=dead_ends)


def door_steps(start: str, links: Mapping[str, set[str]], ends: set[str]) -> dict[str, int]:
    """Breadth-first from `start`: each place reached and how many links away, never
    going on through an end (one may enter a bathroom, not cross it)."""
    steps = {start: 0}
    queue = deque([start])
    while queue:
        here = queue.popleft()
        if here in ends:
            continue
        for there in sorted(links[here]):
            if there not in steps:
                steps[there] = steps[here] + 1
                queue.append(there)
    return steps


def door_segment(
    wall: LineString, width: float, *, centre: Point | None = None
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """A `width` opening on a straight `wall`, at `centre` (default: the middle) moved
    as little as needed to stay `CORNER_CLEARANCE` from the wall's ends; None when
    the wall is too short.

    >>> door_segment(LineString([(0, 0), (4, 0)]), 0.9)
    ((1.55, 0.0), (2.45, 0.0))
    >>> door_segment(LineString([(0, 0), (4, 0)]), 0.9, centre=Point(0.2, 0))
    ((0.1, 0.0), (1.0, 0.0))
    >>> door_segment(LineString([(0, 0), (0.8, 0)]), 0.9) is None
    True

    A wall exactly a door wide (an adjacency's minimum contact) takes the door, without
    clearance, within the checker's tolerance:

    >>> door_segment(LineString([(0, 0), (0.89999, 0)]), 0.9)
    ((0.0, 0.0), (0.89999, 0.0))
    """
    length = wall.length
    if length < width - WALL_TOLERANCE:
        return None
    width = min(width, length)
    clearance = min(CORNER_CLEARANCE, (length - width) / 2)
    at = length / 2 if centre is None else wall.project(centre)
    at = min(max(at, clearance + width / 2), length - clearance - width / 2)
    start, end = wall.interpolate(at - width / 2), wall.interpolate(at + width / 2)
    return ((round(start.x, 6), round(start.y, 6)), (round(end.x, 6), round(end.y, 6)))


def _larger(rooms: Mapping[str, Polygon], a: str, b: str) -> str:
    """Doors swing into the larger room: it has the floor space for the leaf."""
    return a if rooms[a].area >= rooms[b].area else b
