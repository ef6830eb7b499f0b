"""The repair search that makes a first network where no comb is valid, and the grid
lines anchored on an exit: small meshes, checked by walks and counts written here."""

from __future__ import annotations

import itertools
import math

from shapely.geometry import box

from floorplan.solver.network import Feature, NetworkSpec, grid_mesh
from floorplan.solver.network.repair import repaired_network


def test_grid_lines_run_from_an_exit_inside_the_floor() -> None:
    """An exit at x = 7 on a 20 m side at a 3 m pitch lies on a grid line; cells keep
    to the pitch (the outer ones up to one and a half)."""
    mesh = grid_mesh(box(0, 0, 20, 9), (3.0, 3.0), anchors=[(7.0, 0.0)])
    assert any(abs(x - 7.0) < 1e-9 for x in mesh.xs)
    sizes = [b - a for a, b in itertools.pairwise(mesh.xs)]
    assert all(1.5 - 1e-9 <= s <= 4.5 + 1e-9 for s in sizes)
    assert mesh.xs[0] == 0 and mesh.xs[-1] == 20
    assert any(math.dist(p, (7.0, 0.0)) < 1e-9 for p in mesh.points)


def test_every_exit_gets_a_grid_line_where_the_cells_allow() -> None:
    """Exits at x = 7 and x = 15.5 (a core's side) both lie on grid lines, and so do
    their points (the sinks are the exits themselves); no cell is thinner than half a
    pitch. With lines from the first exit only, x = 15.5 lay 1.5 m off every line."""
    mesh = grid_mesh(box(0, 0, 20, 9), (3.0, 3.0), anchors=[(7.0, 0.0), (15.5, 9.0)])
    for x in (7.0, 15.5):
        assert any(abs(line - x) < 1e-9 for line in mesh.xs)
    sizes = [b - a for a, b in itertools.pairwise(mesh.xs)]
    assert all(1.5 - 1e-9 <= s <= 4.5 + 1e-9 for s in sizes)
    assert any(math.dist(p, (15.5, 9.0)) < 1e-9 for p in mesh.points)


def test_repair_makes_a_valid_network_from_the_whole_mesh() -> None:
    """From every edge active (every cell's opposite sides both on: too close) the
    toggles end at a network with no pair too close, every cell along it, both exits
    reached and joined, and no dead end over the cap."""
    mesh = grid_mesh(box(0, 0, 15, 12), 3.0)
    sinks = tuple(next(v for v, p in enumerate(mesh.points) if math.dist(p, e) < 1e-6)
                  for e in ((0, 6), (15, 6)))
    spec = NetworkSpec(mesh, sinks, faces_covered=True, join_sinks=True, dead_end=3.0,
                       too_close=Feature.FORBID)
    edges = repaired_network(spec, [list(range(len(mesh.edges)))], time_limit=60.0)
    assert edges is not None
    chosen = set(edges)
    assert not any(a in chosen and b in chosen for a, b in mesh.opposite)
    assert all(any(x in chosen for x in sides) for sides in mesh.faces)
    adjacent: dict[int, set[int]] = {}
    for x in chosen:
        i, j = mesh.edges[x]
        adjacent.setdefault(i, set()).add(j)
        adjacent.setdefault(j, set()).add(i)
    seen, todo = {sinks[0]}, [sinks[0]]
    while todo:
        for w in adjacent.get(todo.pop(), ()):
            if w not in seen:
                seen.add(w)
                todo.append(w)
    assert sinks[1] in seen and set(adjacent) <= seen
    # Dead ends: from each tip along vertices of degree 2 to a junction or sink.
    for tip, near in adjacent.items():
        if len(near) != 1 or tip in sinks:
            continue
        length, here, came = 0.0, tip, -1
        while True:
            there = next(w for w in adjacent[here] if w != came)
            length += math.dist(mesh.points[here], mesh.points[there])
            came, here = here, there
            if here in sinks or len(adjacent[here]) != 2:
                break
        assert length <= 3.0 + 1e-9
