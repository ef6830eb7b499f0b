"""Sizes for a row plan (`solver.heuristics.slicing`): one small MILP over the widths of the
rooms in each row and the depths of the rows, with the rooms' size, ratio, guide-point
and contact demands, and the rectangles it gives."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from pyscipopt import Model, quicksum

from floorplan.models import Room
from floorplan.solver.geometry import Box, Edge
from floorplan.solver.heuristics.row_search import Demands, RowPlan


def size_bounds(room: Room) -> tuple[tuple[float, float], tuple[float, float]]:
    """(min, max) width and (min, max) depth of a room; unbounded means the domain."""
    lo = room.min_size or (0.0, 0.0)
    hi = room.max_size or (math.inf, math.inf)
    return (lo[0], hi[0]), (lo[1], hi[1])


def aimed_size(room: Room, typical: float) -> tuple[float, float]:
    return room.target_size or room.max_size or (typical, typical)


def size_rows(
    plan: RowPlan, typical: float, *, deadline: float, demands: Demands | None = None
) -> tuple[float, dict[str, Box]] | None:
    """The convex QP: row heights, column widths and room depths minimising E_size
    (Eq. 6) under the rooms' bounds and, with `demands`, the contacts and exterior edges
    the plan's structure allows (a binary only where a demand has several ways to hold)."""
    m = Model("slicing")
    m.hideOutput()
    m.setParam("limits/time", max(0.05, deadline - time.monotonic()))
    m.setParam("limits/gap", 1e-4)
    q = _Sizes(m)
    errors = []
    for g, (region, rows) in enumerate(zip(plan.regions, plan.rows, strict=True)):
        if not rows:
            continue
        y_row: Any = float(region.y0)  # then an expression: the heights so far
        row_heights = []
        for k, row in enumerate(rows):
            h = m.addVar(f"h[{g},{k}]", lb=0, ub=region.depth)
            row_heights.append(h)
            q.row_height[g, k] = h
            x: Any = float(region.x0)
            col_widths = []
            for c, col in enumerate(row):
                w_lo = max(size_bounds(r)[0][0] for r in col)
                w_hi = min(min(size_bounds(r)[0][1] for r in col), region.width)
                if w_lo > w_hi:
                    return None
                w = m.addVar(f"w[{g},{k},{c}]", lb=w_lo, ub=w_hi)
                col_widths.append(w)
                depths = _size_column(q, col, region, w, h, (x, y_row), typical, errors)
                if len(col) > 1:
                    m.addCons(quicksum(depths) == h, name=f"fill_column[{g},{k},{c}]")
                x = x + w
            m.addCons(quicksum(col_widths) == region.width, name=f"fill_row[{g},{k}]")
            y_row = y_row + h
        m.addCons(quicksum(row_heights) == region.depth, name=f"fill_region[{g}]")
    for rows in plan.rows:
        for room in (room for row in rows for col in row for room in col):
            if not _c_pos(q, room):
                return None
    if demands and not _demands(q, plan, demands):
        return None
    m.setObjective(quicksum(errors) if errors else 0)
    m.optimize()
    if m.getNSols() == 0:
        return None
    return m.getObjVal(), _boxes(plan, q, m.getBestSol())


def _size_column(q: _Sizes, col: Sequence[Room], region: Box, w: Any, h: Any,
                 corner: tuple[Any, Any], typical: float, errors: list[Any]) -> list[Any]:
    """The rooms of one column, stacked from `corner` (its south-west, expressions of
    the widths and heights before it) in a column `w` wide of a row `h` deep: each
    room's depth, bounds, ratio and size error (added to `errors`); their depths."""
    m = q.model
    x, y = corner
    depths = []
    for room in col:
        (_, (d_lo, d_hi)) = size_bounds(room)
        d = h if len(col) == 1 else m.addVar(
            f"d[{room.id}]", lb=d_lo, ub=min(d_hi, region.depth))
        if len(col) == 1:
            m.addCons(h >= d_lo, name=f"depth_lo[{room.id}]")
            if d_hi < region.depth:
                m.addCons(h <= d_hi, name=f"depth_hi[{room.id}]")
        depths.append(d)
        q.width[room.id], q.west[room.id] = w, x
        q.depth[room.id], q.south[room.id] = d, y
        y = y + d
        _c_ratio(m, room, w, d, typical)
        if room.target_size is not None:
            e = m.addVar(f"e[{room.id}]", lb=0)
            tw, td = room.target_size
            m.addCons((w - tw) * (w - tw) + (d - td) * (d - td) <= e,
                      name=f"size_error[{room.id}]")
            errors.append(e)
    return depths


def _boxes(plan: RowPlan, q: _Sizes, sol: Any) -> dict[str, Box]:
    """The rectangles of a sized plan; the last row, column and room of each cut end
    exactly on the edge they fill."""
    boxes: dict[str, Box] = {}
    for g, (region, rows) in enumerate(zip(plan.regions, plan.rows, strict=True)):
        y0 = region.y0
        for k, row in enumerate(rows):
            y1 = region.y1 if k == len(rows) - 1 else y0 + sol[q.row_height[g, k]]
            x0 = region.x0
            for c, col in enumerate(row):
                x1 = region.x1 if c == len(row) - 1 else x0 + sol[q.width[col[0].id]]
                y = y0
                for j, room in enumerate(col):
                    top = y1 if j == len(col) - 1 else y + sol[q.depth[room.id]]
                    boxes[room.id] = Box(x0, y, x1, top)
                    y = top
                x0 = x1
            y0 = y1
    return boxes


@dataclass
class _Sizes:
    """The QP's variables and expressions per room: its column's width and west side,
    its depth and south side (a number for the first of a cut)."""

    model: Model
    width: dict[str, Any] = field(default_factory=dict)
    west: dict[str, Any] = field(default_factory=dict)
    depth: dict[str, Any] = field(default_factory=dict)
    south: dict[str, Any] = field(default_factory=dict)
    row_height: dict[tuple[int, int], Any] = field(default_factory=dict)

    def span_x(self, room: str) -> tuple[Any, Any]:
        return self.west[room], self.west[room] + self.width[room]

    def span_y(self, room: str) -> tuple[Any, Any]:
        return self.south[room], self.south[room] + self.depth[room]

    def at_most(self, low: Any, high: Any, name: str, slack: Any = 0.0) -> bool:
        """low <= high + slack; False when both sides are numbers and it fails."""
        if all(isinstance(v, float | int) for v in (low, high, slack)):
            return low <= high + slack + 1e-9
        self.model.addCons(low <= high + slack, name=name)
        return True


def _c_pos(q: _Sizes, room: Room) -> bool:
    """C_pos (Eq. 8): the room's rectangle covers each of its guide points."""
    x0, x1 = q.span_x(room.id)
    y0, y1 = q.span_y(room.id)
    return all(
        q.at_most(x0, px, f"pos_w[{room.id}]") and q.at_most(px, x1, f"pos_e[{room.id}]")
        and q.at_most(y0, py, f"pos_s[{room.id}]") and q.at_most(py, y1, f"pos_n[{room.id}]")
        for px, py in room.positions)


def _demands(q: _Sizes, plan: RowPlan, demands: Demands) -> bool:
    """C_adj (Eq. 10-11) and C_boundary (Eq. 9) in the plan's structure: each demand's
    ways to hold, as linear constraints; several ways get a binary each."""
    reach = max(r.x1 for r in plan.regions) - min(r.x0 for r in plan.regions) + max(
        r.y1 for r in plan.regions) - min(r.y0 for r in plan.regions)
    for n, c in enumerate(demands.contacts):
        ways = [_contact_way(q, plan, c.a, p, c.min_contact) for p in c.partners
                if plan.can_touch(c.a, p)]
        if not _any_way(q, ways, reach, f"adj[{n}]"):
            return False
    for room, edges in demands.edges.items():
        ways = [_edge_way(q, room, e) for e in edges if plan.can_lie_on(room, e)]
        if not _any_way(q, ways, reach, f"edge[{room}]"):
            return False
    return True


Way = list[tuple[Any, Any]]  # pairs (low, high): low <= high must hold


def _contact_way(q: _Sizes, plan: RowPlan, a: str, b: str, contact: float) -> Way:
    """Rooms `a` and `b` sharing `contact` metres of wall where the plan has them meet:
    their ranges along the wall overlap by `contact`, i.e. min(a1, b1) - max(a0, b0)
    >= contact, four linear cuts (two of them trivial in one column)."""
    if plan.in_one_column(a, b):
        return [(contact, q.width[a])]
    along_x = plan.along_x(a, b)
    a0, a1 = q.span_x(a) if along_x else q.span_y(a)
    b0, b1 = q.span_x(b) if along_x else q.span_y(b)
    return [(contact + a0, a1), (contact + a0, b1), (contact + b0, a1), (contact + b0, b1)]


def _edge_way(q: _Sizes, room: str, edge: Edge) -> Way:
    """The room's side on `edge` lies within the edge's span, as Eq. 9 asks."""
    lo, hi = edge.span
    start, end = q.span_x(room) if edge.horizontal else q.span_y(room)
    return [(lo, start), (end, hi)]


def _any_way(q: _Sizes, ways: list[Way], reach: float, name: str) -> bool:
    if not ways:
        return False
    if len(ways) == 1:
        return all(q.at_most(lo, hi, f"{name}[{i}]") for i, (lo, hi) in enumerate(ways[0]))
    chosen = [q.model.addVar(f"{name}:way[{j}]", vtype="B") for j in range(len(ways))]
    q.model.addCons(quicksum(chosen) >= 1, name=f"{name}:some_way")
    for j, way in enumerate(ways):
        for i, (lo, hi) in enumerate(way):
            q.at_most(lo, hi, f"{name}[{j},{i}]", slack=reach * (1 - chosen[j]))
    return True


def _c_ratio(m: Model, room: Room, w: object, h: object, typical: float) -> None:
    """C_ratio (Eq. 7) with the orientation of the room's target: linear."""
    if room.aspect_ratio is None:
        return
    lo, hi = room.aspect_ratio
    tw, td = aimed_size(room, typical)
    long, short = (w, h) if tw >= td else (h, w)
    m.addCons(long >= lo * short, name=f"ratio_lo[{room.id}]")
    m.addCons(long <= hi * short, name=f"ratio_hi[{room.id}]")
