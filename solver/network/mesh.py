"""The mesh a network is chosen from (Peng et al. Sec. 4.1, "the input problem domain ...
is discretized into a polygonal mesh M"): a grid of square-ish cells over the free floor.

Vertices are the grid points on or inside the free floor; edges join neighbouring grid
points along a segment inside it. Edges lying along the outline or an obstacle's side are
left out (a corridor centred on a wall would be half outside), as the paper leaves out its
boundary edges (Fig. 2); vertices on the outline stay, so an exit there is a sink reached by
the edge running inwards from it. Pure geometry, no SCIP.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

#: Distances below this (metres) are one point.
EPS = 1e-6

XY = tuple[float, float]


@dataclass(frozen=True)
class Mesh:
    """A graph embedded in the plane: `points` by vertex index, `edges` as (i, j) with
    i < j, and the pairs of opposite edges of each grid cell (`opposite`: two corridors
    a cell apart, the paper's "edges too close", Eq. 12)."""

    points: list[XY]
    edges: list[tuple[int, int]]
    opposite: list[tuple[int, int]] = field(default_factory=list)
    pitch: tuple[float, float] = (1.0, 1.0)
    #: Per grid cell inside the floor, the mesh edges on its sides (its outline sides are
    #: not mesh edges).
    faces: list[list[int]] = field(default_factory=list)

    @property
    def lengths(self) -> list[float]:
        return [math.dist(self.points[i], self.points[j]) for i, j in self.edges]

    def incident(self) -> list[list[int]]:
        """Per vertex, the indices of its edges."""
        out: list[list[int]] = [[] for _ in self.points]
        for x, (i, j) in enumerate(self.edges):
            out[i].append(x)
            out[j].append(x)
        return out

    def other(self, edge: int, vertex: int) -> int:
        i, j = self.edges[edge]
        return j if vertex == i else i

    def nearest(self, point: XY, *, with_edges: bool = True) -> int:
        """The vertex nearest `point` (among those with an edge, by default)."""
        incident = self.incident()
        candidates = [v for v in range(len(self.points)) if incident[v] or not with_edges]
        return min(candidates, key=lambda v: math.dist(self.points[v], point))


def grid_mesh(free: BaseGeometry, pitch: float, *, anchors: Sequence[XY] = ()) -> Mesh:
    """The grid mesh of `free` at about `pitch` metres: the bounding box is cut into
    whole cells (so the grid ends on the outline), each axis's pitch the nearest to
    `pitch` that does; where `anchors` (exits) lie on a side, the count of cells is
    chosen among the nearest few so that as many anchors as possible fall on grid lines."""
    x0, y0, x1, y1 = free.bounds
    nx = _cells(x1 - x0, pitch, [a[0] - x0 for a in anchors])
    ny = _cells(y1 - y0, pitch, [a[1] - y0 for a in anchors])
    px, py = (x1 - x0) / nx, (y1 - y0) / ny
    grown = free.buffer(EPS, join_style="mitre")
    shapely.prepare(grown)
    boundary = free.boundary
    index: dict[tuple[int, int], int] = {}
    points: list[XY] = []
    for i in range(nx + 1):
        for j in range(ny + 1):
            p = (x0 + i * px, y0 + j * py)
            if grown.contains(Point(p)):
                index[(i, j)] = len(points)
                points.append(p)
    edges: list[tuple[int, int]] = []
    edge_at: dict[tuple[int, int, int], int] = {}  # (i, j, 0 east | 1 north) -> edge
    for (i, j), v in index.items():
        for d, (di, dj) in enumerate(((1, 0), (0, 1))):
            w = index.get((i + di, j + dj))
            if w is None:
                continue
            segment = LineString([points[v], points[w]])
            if not grown.contains(segment):
                continue
            if boundary.distance(segment.interpolate(0.5, normalized=True)) <= EPS:
                continue  # along a wall
            edge_at[(i, j, d)] = len(edges)
            edges.append((min(v, w), max(v, w)))
    opposite = []
    faces = []
    for i in range(nx):
        for j in range(ny):
            for a, b in (((i, j, 0), (i, j + 1, 0)), ((i, j, 1), (i + 1, j, 1))):
                if a in edge_at and b in edge_at:
                    opposite.append((edge_at[a], edge_at[b]))
            centre = Point(x0 + (i + 0.5) * px, y0 + (j + 0.5) * py)
            if grown.contains(centre):
                sides = [
                    edge_at[k]
                    for k in ((i, j, 0), (i, j + 1, 0), (i, j, 1), (i + 1, j, 1))
                    if k in edge_at
                ]
                faces.append(sides)
    return Mesh(points, edges, opposite, (px, py), faces)


def _cells(length: float, pitch: float, offsets: Sequence[float]) -> int:
    """How many cells cut a side of `length`: near `length / pitch`, preferring counts
    that put the anchors' offsets on grid lines."""
    base = max(1, round(length / pitch))
    choices = range(max(1, base - 2), base + 3)

    def misses(n: int) -> tuple[int, float]:
        step = length / n
        off = [o for o in offsets if EPS < o < length - EPS]
        missed = sum(1 for o in off if abs(o / step - round(o / step)) * step > 1e-3)
        return missed, abs(step - pitch)

    return min(choices, key=misses)


def cell_polygon(
    mesh: Mesh, edges: Sequence[int], width: float, free: BaseGeometry
) -> BaseGeometry:
    """The corridor floor of `edges`: each edge's centre line widened to `width` (square
    ends, mitred joins), united and clipped to the free floor."""
    if not edges:
        return Polygon()
    lines = [
        LineString([mesh.points[mesh.edges[x][0]], mesh.points[mesh.edges[x][1]]]) for x in edges
    ]
    shape = shapely.union_all(
        [line.buffer(width / 2, cap_style="square", join_style="mitre") for line in lines]
    )
    return shape.intersection(free)
