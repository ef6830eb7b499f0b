"""How many different plans a batch holds (docs/cli.md, "floorplan batch"): plans
compared as pictures, and their adjacency graphs.

Two plans are the same when at most `SAME_PLAN_SHARE` of their floor belongs to a
different room (or to no room in one of them), the floor drawn on a grid of
`CELL` metres. A plan whose every room moved by a few centimetres is then the same
plan, as a user looking at both would say; a kitchen that swapped sides is not.
`DistinctPlans` counts a batch's plans greedily: a plan is new when it differs from
every plan counted before it.

A plan's adjacency graph is the set of room pairs sharing at least `MIN_CONTACT` metres
of wall; rooms are compared by id (a brief names its rooms once for every seed).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon

from floorplan.models import Layout, RoomLayout

#: Side of a grid cell when plans are compared, metres.
CELL = 0.1
#: Plans differing on at most this share of their floor's cells are the same plan.
SAME_PLAN_SHARE = 0.05
#: Plans differing from a plan on at most this share of the floor are the ones moving its
#: walls (solver/pipeline/spread.py) may land on or near: what a spread is given.
NEAR_SHARE = 0.25
#: Two rooms are adjacent in the graph when they share this much wall, metres.
MIN_CONTACT = 0.5


def _floors(layout: Layout) -> list[list[RoomLayout]]:
    return [layout.rooms] if layout.floors is None else [f.rooms for f in layout.floors]


def raster(layout: Layout, *, cell: float = CELL) -> tuple[tuple[str, ...], np.ndarray]:
    """The plan as a grid of room numbers (0: no room), floor after floor, with the room
    ids the numbers stand for (1-based, sorted) and the grid's origin at the lower left
    of the rooms' bounds."""
    ids = tuple(sorted({r.id for r in layout.all_rooms}))
    number = {room_id: k + 1 for k, room_id in enumerate(ids)}
    grids = [floor_grid([(number[r.id], b.x, b.y, b.x + b.width, b.y + b.depth)
                         for r in floor for b in r.rectangles], cell=cell)
             for floor in _floors(layout)]
    grids = [g for g in grids if g.size]
    return ids, np.concatenate(grids) if grids else np.zeros(0, dtype=np.int32)


def floor_grid(boxes: Sequence[tuple[int, float, float, float, float]], *, cell: float = CELL
               ) -> np.ndarray:
    """One floor's rectangles (room number, x0, y0, x1, y1) as a flat grid of room
    numbers (`raster`); empty without rectangles."""
    if not boxes:
        return np.zeros(0, dtype=np.int32)
    x0 = min(b[1] for b in boxes)
    y0 = min(b[2] for b in boxes)
    nx = round(max(b[3] for b in boxes) / cell - x0 / cell)
    ny = round(max(b[4] for b in boxes) / cell - y0 / cell)
    grid = np.zeros((max(ny, 1), max(nx, 1)), dtype=np.int32)
    for k, bx0, by0, bx1, by1 in boxes:
        grid[round((by0 - y0) / cell):round((by1 - y0) / cell),
             round((bx0 - x0) / cell):round((bx1 - x0) / cell)] = k
    return grid.ravel()


def adjacency_graph(layout: Layout, *, min_contact: float = MIN_CONTACT
                    ) -> frozenset[tuple[str, str]]:
    """The pairs of rooms (ids, sorted) sharing at least `min_contact` metres of wall,
    on any floor."""
    pairs: set[tuple[str, str]] = set()
    for floor in _floors(layout):
        shapes = {r.id: Polygon(r.polygon) for r in floor if len(r.polygon) >= 3}
        for (a, pa), (b, pb) in itertools.combinations(sorted(shapes.items()), 2):
            if shapely.length(pa.boundary.intersection(pb.boundary)) >= min_contact:
                pairs.add((a, b))
    return frozenset(pairs)


class DistinctPlans:
    """Counts the different plans and adjacency graphs among the layouts `add`ed."""

    def __init__(self, *, share: float = SAME_PLAN_SHARE, cell: float = CELL,
                 graphs: bool = True) -> None:
        self.share = share
        self.cell = cell
        #: Whether adjacency graphs are counted too (their geometry costs about 1 ms a
        #: layout; a set of plans to compare against needs none).
        self.count_graphs = graphs
        self._plans: dict[tuple[tuple[str, ...], int], list[np.ndarray]] = {}
        self._graphs: set[frozenset[tuple[str, str]]] = set()
        self.layouts = 0

    def add(self, layout: Layout) -> bool:
        """Count `layout`; True when its plan is new."""
        self.layouts += 1
        if self.count_graphs:
            self._graphs.add(adjacency_graph(layout))
        ids, grid = raster(layout, cell=self.cell)
        if not self._is_new(ids, grid):
            return False
        self._plans.setdefault((ids, grid.size), []).append(grid)
        return True

    def is_new(self, layout: Layout) -> bool:
        """Whether `layout`'s plan differs from every plan counted (it is not counted)."""
        return self._is_new(*raster(layout, cell=self.cell))

    def near(self, layout: Layout, within: float) -> np.ndarray:
        """The grids of the plans counted that differ from `layout`'s on at most `within`
        of its cells (a stack, one row a plan; no rows when none)."""
        ids, grid = raster(layout, cell=self.cell)
        same_shape = self._plans.get((ids, grid.size))
        if not same_shape:
            return np.zeros((0, grid.size), dtype=np.int32)
        stack = np.stack(same_shape)
        return stack[(stack != grid).sum(axis=1) <= within * grid.size]

    def _is_new(self, ids: tuple[str, ...], grid: np.ndarray) -> bool:
        same_shape = self._plans.get((ids, grid.size))
        if not same_shape:
            return True
        differing = (np.stack(same_shape) != grid).sum(axis=1)
        return bool(differing.min() > self.share * grid.size)

    @property
    def plans(self) -> int:
        return sum(len(grids) for grids in self._plans.values())

    @property
    def graphs(self) -> int:
        return len(self._graphs)


def count_distinct(layouts: Sequence[Layout]) -> tuple[int, int]:
    """(distinct plans, distinct adjacency graphs) among `layouts`."""
    counter = DistinctPlans()
    for layout in layouts:
        counter.add(layout)
    return counter.plans, counter.graphs
