"""A floor with `corridors`, end to end with the real SCIP: the corridors reach both
exits as one network, no room overlaps them, and the report's walks agree with a walk
over a raster of the corridor polygons computed here (four neighbours, so never
shorter than a real walk along straight corridors)."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, Polygon

from floorplan.models import Layout, Problem
from floorplan.solver.pipeline.dispatch import solve

EXITS = [(0.0, 6.0), (30.0, 6.0)]
CELL = 0.1


def _problem() -> Problem:
    return Problem.model_validate(
        {
            "name": "corridor-floor",
            "boundary": [[0, 0], [30, 0], [30, 12], [0, 12]],
            "rooms": [
                {"id": f"r{k}", "type": "office", "target_size": [3.6, 3.2], "min_size": [2.0, 2.0]}
                for k in range(14)
            ],
            "corridors": {"exits": EXITS, "width": 1.8, "max_travel": 30, "dead_ends": 6},
            "options": {"time_limit": 30, "seed": 0},
        }
    )


class _Raster:
    """The corridors as 4-neighbour raster cells of side CELL: our own measure of walks,
    independent of the report's."""

    def __init__(self, corridors: Polygon) -> None:
        x0, y0, x1, y1 = corridors.bounds
        nx, ny = math.ceil((x1 - x0) / CELL), math.ceil((y1 - y0) / CELL)
        self.gx, self.gy = np.meshgrid(
            x0 + (np.arange(nx) + 0.5) * CELL, y0 + (np.arange(ny) + 0.5) * CELL, indexing="ij"
        )
        self.inside = shapely.contains_xy(corridors, self.gx, self.gy)
        self.cells = np.argwhere(self.inside)

    def nearest(self, p: tuple[float, float]) -> tuple[int, int, float]:
        """The corridor cell nearest `p`, and the straight leg from `p` to its centre."""
        d = np.hypot(self.gx[self.inside] - p[0], self.gy[self.inside] - p[1])
        k = int(np.argmin(d))
        return int(self.cells[k][0]), int(self.cells[k][1]), float(d[k])

    def steps(self, sources: list[tuple[float, float]]) -> np.ndarray:
        """Breadth-first steps from the cells nearest `sources` (-1: not reached)."""
        nx, ny = self.inside.shape
        steps = np.full((nx, ny), -1)
        queue = deque()
        for p in sources:
            i, j, _ = self.nearest(p)
            steps[i, j] = 0
            queue.append((i, j))
        while queue:
            i, j = queue.popleft()
            for a, b in ((i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)):
                if 0 <= a < nx and 0 <= b < ny and self.inside[a, b] and steps[a, b] < 0:
                    steps[a, b] = steps[i, j] + 1
                    queue.append((a, b))
        return steps


def _walks(corridors: Polygon, doors: dict[str, tuple[float, float]]) -> dict[str, float]:
    """Breadth-first over 4-neighbour raster cells from the exits' cells."""
    raster = _Raster(corridors)
    steps = raster.steps(EXITS)
    return {room: float(steps[raster.nearest(p)[:2]]) * CELL for room, p in doors.items()}


@pytest.mark.slow
def test_corridors_from_their_specification() -> None:
    layout: Layout = solve(_problem())
    assert layout.corridors and not layout.aisles
    egress = layout.report.egress
    assert egress is not None
    union = shapely.union_all([Polygon(c.polygon) for c in layout.corridors])
    rooms = shapely.union_all([Polygon(r.polygon) for r in layout.rooms])
    assert union.intersection(rooms).area < 1e-3
    assert all(union.distance(Point(e)) < 1e-3 for e in EXITS)
    assert len(getattr(union.buffer(1e-4), "geoms", [union])) == 1  # one network
    assert abs(egress.corridor_area - union.area) < 1e-2
    names = {c.id for c in layout.corridors}
    doors = {
        d.between[1]: (
            (d.segment[0][0] + d.segment[1][0]) / 2,
            (d.segment[0][1] + d.segment[1][1]) / 2,
        )
        for d in layout.doors
        if d.between[0] in names
    }
    assert set(doors) | set(egress.rooms_without_access) == {r.id for r in layout.rooms}
    mine = _walks(union, doors)
    for room, walk in mine.items():
        # Four-neighbour steps never undercut the report's eight-neighbour walk by more
        # than the rasters' cells; along straight corridors they agree within a metre.
        assert egress.travel[room] <= walk + 0.5, (room, egress.travel[room], walk)
        assert walk <= egress.travel[room] * math.sqrt(2) + 1.0
    check = {c.kind: c for c in layout.report.constraints}
    assert check["max_travel"].satisfied == (max(egress.travel.values()) <= 30.2)
    assert check["dead_ends"].satisfied == all(d <= 6.2 for d in egress.dead_ends)


def _walk_between(corridors: Polygon, a: tuple[float, float], b: tuple[float, float]) -> float:
    """Four-neighbour raster walk from the corridor cell nearest `a` to the one nearest
    `b`, plus the straight legs onto them."""
    raster = _Raster(corridors)
    (_, _, leg_a), (bi, bj, leg_b) = raster.nearest(a), raster.nearest(b)
    steps = raster.steps([a])
    if steps[bi, bj] < 0:
        return math.inf
    return float(steps[bi, bj]) * CELL + leg_a + leg_b


@pytest.mark.slow
def test_a_route_is_planned_measured_and_checked() -> None:
    """`corridors.routes` (Eq. 7-8 with a walk limit): the report's walk between the
    route's points agrees with a raster walk of our own over the corridor polygons,
    and the `route` check says whether it is within `max_walk`."""
    a, b = (1.0, 11.0), (29.0, 1.0)
    data = _problem().model_dump(mode="json", exclude_none=True)
    data["corridors"]["routes"] = [{"between": [list(a), list(b)], "max_walk": 44}]
    layout: Layout = solve(Problem.model_validate(data))
    assert layout.corridors
    egress = layout.report.egress
    assert egress is not None and len(egress.routes) == 1
    union = shapely.union_all([Polygon(c.polygon) for c in layout.corridors])
    mine = _walk_between(union, a, b)
    reported = egress.routes[0]
    assert reported is not None and math.isfinite(mine)
    # The report walks eight neighbours, ours four: never shorter, at most sqrt(2) more.
    assert reported <= mine + 0.5
    assert mine <= reported * math.sqrt(2) + 1.0
    (check,) = [c for c in layout.report.constraints if c.kind == "route"]
    assert check.satisfied == (reported <= 44.2)
