"""Blocks cut into strips along their corridors (geometry only, no SCIP): an L-shaped
block (a column along one corridor joined to a row along another) gives one strip per
corridor, neither cut across, and the rooms are dealt no deeper than a cell; a floor's
corner cell needs no corridor and becomes a one-room strip with a door; rooms are
dealt by how their depth suits a strip."""

from __future__ import annotations

import itertools

import shapely
from shapely.geometry import LineString, box

from floorplan.models import Problem, Room
from floorplan.solver.network import Mesh, grid_mesh
from floorplan.solver.pipeline.regions.corridor_strips import CornerRoom, _strips
from floorplan.solver.pipeline.regions.corridors import network_spec, walkable_pitch
from floorplan.solver.pipeline.regions.parts import assign_to_parts


def test_an_l_shaped_block_gives_a_column_and_a_row() -> None:
    mesh = grid_mesh(box(0, 0, 20, 12), (4.0, 4.0))
    lines = [LineString([(4, 4), (4, 12)]), LineString([(4, 4), (20, 4)])]
    corridors = shapely.union_all(
        [ln.buffer(0.9, cap_style="square", join_style="mitre") for ln in lines]
    ).intersection(box(0, 0, 20, 12))
    block = box(0, 0, 20, 12).difference(corridors).difference(box(4.9, 4.9, 20, 12))
    strips, floor = _strips(block, mesh, corridors, 1.0)
    assert not floor
    assert len(strips) == 2
    grown = corridors.buffer(1e-4, join_style="mitre")
    for strip in strips:
        assert strip.boundary.intersection(grown).length > 3.0  # along its corridor
    tall = max(strips, key=lambda s: s.bounds[3] - s.bounds[1])
    wide = max(strips, key=lambda s: s.bounds[2] - s.bounds[0])
    assert tall.bounds[3] - tall.bounds[1] >= 8.0 and tall.bounds[2] <= 4.0
    assert wide.bounds[2] - wide.bounds[0] >= 15.0 and wide.bounds[3] <= 4.0
    assert abs(sum(s.area for s in strips) - block.area) < 1e-3


def test_a_grid_is_chosen_whose_every_cell_can_reach_an_exit() -> None:
    """Exits mid-south and mid-north of a 70 x 34 m floor, 45 m: at a 4.92 m pitch the
    cells at the middle of the side walls have no side within the walk (the IP would be
    infeasible); the pitch chosen nearby has every cell's side within reach, walked
    along x and y from the nearest exit (checked here)."""
    problem = Problem.model_validate({
        "name": "two-exits",
        "boundary": [[0, 0], [70, 0], [70, 34], [0, 34]],
        "rooms": [{"id": "a", "type": "shop", "target_size": [4.5, 3.5]}],
        "corridors": {"exits": [[35, 0], [35, 34]], "width": 1.8, "max_travel": 45},
    })
    corridors = problem.corridors
    assert corridors is not None
    cap = 45 - 0.9

    def reachable(mesh: Mesh) -> bool:
        def near(x: int) -> bool:
            (ax, ay), (bx, by) = (mesh.points[v] for v in mesh.edges[x])
            m = ((ax + bx) / 2, (ay + by) / 2)
            return min(abs(m[0] - e[0]) + abs(m[1] - e[1]) for e in corridors.exits) <= cap
        return all(any(near(x) for x in sides) for sides in mesh.faces)

    free = problem.free_area()
    assert not reachable(grid_mesh(free, (4.92, 4.02), anchors=corridors.exits))
    pitch, thinnest = walkable_pitch(problem, corridors, (4.92, 4.02))
    assert reachable(grid_mesh(free, pitch, anchors=corridors.exits, thinnest=thinnest))
    assert all(0.85 * a <= b <= 1.15 * a for a, b in zip((4.92, 4.02), pitch, strict=True))


def _corner_floor() -> tuple[Mesh, shapely.Polygon, list[shapely.Polygon]]:
    """A 20 x 12 m floor at a 4 m pitch with a corridor along y = 4 from x = 4 east and
    one along x = 4 from y = 4 north: the cell in the south-west corner has neither on
    a side of its own; the block south of y = 4 is a row along the first."""
    mesh = grid_mesh(box(0, 0, 20, 12), (4.0, 4.0))
    lines = [LineString([(4, 4), (4, 12)]), LineString([(4, 4), (20, 4)])]
    corridors = shapely.union_all(
        [ln.buffer(0.9, cap_style="square", join_style="mitre") for ln in lines]
    ).intersection(box(0, 0, 20, 12))
    blocks = [p for p in getattr(box(0, 0, 20, 12).difference(corridors), "geoms", [])]
    return mesh, corridors, blocks


def test_a_floor_corner_cell_needs_no_corridor_of_its_own() -> None:
    """`network_spec` leaves the floor's four corner cells out of the cells a corridor
    must run along (each has two sides on the outline), and only those."""
    problem = Problem.model_validate({
        "name": "corners",
        "boundary": [[0, 0], [20, 0], [20, 12], [0, 12]],
        "rooms": [{"id": "a", "type": "office", "target_size": [3.1, 3.1]}],
        "corridors": {"exits": [[0, 6]], "width": 1.8},
    })
    assert problem.corridors is not None
    spec = network_spec(problem, problem.corridors, (4.0, 4.0))
    whole = grid_mesh(problem.free_area(), (4.0, 4.0), anchors=problem.corridors.exits)
    assert len(whole.faces) - len(spec.mesh.faces) == 4
    assert all(len(sides) > 2 for sides in spec.mesh.faces)


def test_the_corner_piece_and_a_strip_end_make_a_room_with_a_door() -> None:
    """The south-west corner piece (no corridor on its sides) takes the end of the row
    along the corridor at y = 4 up to `reach` past the corridor's end: one strip of one
    room that shares at least `reach` of wall with the corridor; the rest of the row and
    the column keep theirs, and no floor is lost."""
    mesh, corridors, blocks = _corner_floor()
    # The L: the column west of x = 3.1 and the row south of y = 3.1.
    (block,) = [b for b in blocks if b.distance(shapely.Point(0, 0)) < 1e-9]
    singles: list[shapely.Polygon] = []
    corner = CornerRoom(1.3, (3.1, 3.1), ((0.0, 0.0), (20.0, 0.0), (20.0, 12.0), (0.0, 12.0)))
    strips, floor = _strips(block, mesh, corridors, 1.0, corner=corner, singles=singles)
    assert len(singles) == 1
    (room,) = singles
    grown = corridors.buffer(1e-4, join_style="mitre")
    assert room.boundary.intersection(grown).length >= 1.3 - 1e-6
    assert room.distance(shapely.Point(0, 0)) < 1e-9
    for strip in strips:
        assert strip.boundary.intersection(grown).length >= 1.3 - 1e-6
    assert abs(sum(s.area for s in strips) + sum(f.area for f in floor) - block.area) < 1e-3


def test_rooms_are_dealt_by_how_their_depth_suits_a_strip() -> None:
    """Two rows along corridors, 2.5 and 3.5 m deep, and a one-room corner strip: with
    `fit` the rooms asked 3.5 m deep go to the deep row and those asked 2.5 m deep to the
    shallow one (by area alone they are spread over both); the corner strip, at most
    one room (`most`), gets exactly one."""
    rooms = [{"id": f"d{k}", "type": "office", "target_size": [3.0, 3.5]} for k in range(4)]
    rooms += [{"id": f"s{k}", "type": "office", "target_size": [3.0, 2.5]} for k in range(4)]
    rooms += [{"id": "c", "type": "office", "target_size": [3.0, 3.0]}]
    problem = Problem.model_validate({
        "name": "rows",
        "boundary": [[0, 0], [20, 0], [20, 20], [0, 20]],
        "rooms": rooms,
    })
    shallow, deep, corner = box(0, 0, 12, 2.5), box(0, 10, 12, 13.5), box(15, 0, 18, 3)
    depth = {shallow.wkb: 2.5, deep.wkb: 3.5, corner.wkb: 3.0}

    def fit(part: shapely.Polygon, room: Room) -> float:
        assert room.target_size is not None
        return (depth[part.wkb] - room.target_size[1]) ** 2

    def most(part: shapely.Polygon) -> int | None:
        return 1 if part.wkb == corner.wkb else None

    dealt = assign_to_parts(problem, problem.rooms, [shallow, deep, corner], fit=fit,
                            most=most)
    assert sorted(r.id for r in dealt[0]) == ["s0", "s1", "s2", "s3"]
    assert sorted(r.id for r in dealt[1]) == ["d0", "d1", "d2", "d3"]
    assert [r.id for r in dealt[2]] == ["c"]
    by_area = assign_to_parts(problem, problem.rooms, [shallow, deep, corner])
    assert {r.id[0] for r in by_area[0]} != {"s"}


def test_a_cores_sides_are_grid_lines_and_its_rows_room_deep() -> None:
    """A 48 x 24 m floor with a 6 x 4 m core at (21, 10) and an exit on its west side:
    the planning grid has lines along the core's west and east sides (two cells cut by
    it each kept two sides, and no network was found), but none along its south and
    north sides (2 m from the exit's line: rows 1.1 m deep beside the core); the cells
    the core leaves thin need no corridor of their own, and the lines are spread evenly
    between the anchors' (no 6.6 m or 3 m end columns)."""
    problem = Problem.model_validate({
        "name": "core",
        "boundary": [[0, 0], [48, 0], [48, 24], [0, 24]],
        "obstacles": [{"x": 21, "y": 10, "width": 6, "depth": 4, "label": "core"}],
        "rooms": [{"id": "a", "type": "office", "target_size": [4.0, 3.1]}],
        "corridors": {"exits": [[0, 12], [48, 12], [21, 12]], "width": 1.8},
    })
    assert problem.corridors is not None
    mesh = network_spec(problem, problem.corridors, (4.8, 3.9)).mesh
    for x in (21.0, 27.0):
        assert any(abs(line - x) < 1e-9 for line in mesh.xs)
    assert not any(0 < abs(line - 12.0) < 3.0 for line in mesh.ys)
    for lines, pitch in ((mesh.xs, 4.8), (mesh.ys, 3.9)):
        cells = [b - a for a, b in itertools.pairwise(lines)
                 if not (a >= 21.0 - 1e-9 and b <= 27.0 + 1e-9 and lines is mesh.xs)]
        assert all(0.8 * pitch <= c <= 1.2 * pitch for c in cells), cells
    core = box(21, 10, 27, 14)
    assert not any(box(*cell).intersection(core).area > 0 for cell in mesh.cells)
