"""Row plans for problems with demands that couple rooms (adjacency, Eq. 10-11) or tie
them to the outline (boundary, Eq. 9): which room goes where in rows of columns.

Each rectangle of free floor is cut into rows, each row into columns, each column into
rooms stacked south to north (a slicing tree three cuts deep). A plan fixes every
relation the MIQP's binaries would choose: rooms one above the other in a column share
a wall as wide as the column; rooms of neighbouring columns share the line between the
columns and touch where their y-ranges overlap; the top room of a column and the bottom
room of a column in the row above touch where their x-ranges overlap; the bottom room
of a bottom row lies on its rectangle's south side, the rooms of a first column on its
west side. So whether a demand *can* hold in a plan is a question of structure,
answered here without any solver, and the annealing below looks for a plan where every
demand can and the rough sizes fit; the convex QP of `solver.heuristics.slicing` then sets the
sizes, with each demand a linear constraint.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass

from floorplan.models import Problem, Room
from floorplan.solver.geometry import Box, Domain, Edge, edges_named

#: Touching tolerance for lines of the floor's rectangles, metres.
LINE_TOL = 1e-6
#: Weight of one demand that cannot hold against the E_size estimate (m²): any plan
#: where every demand can hold beats any plan where one cannot.
DEMAND_WEIGHT = 1e4
#: Weight of a metre of size bounds that cannot fill the floor, or of a guide point
#: away from its room's row.
MISFIT_WEIGHT = 1e3
#: The annealing's first temperature, in metres of misfit (times `MISFIT_WEIGHT`), and
#: its last, in m² of E_size.
HOT = 0.3
COLD = 0.05
#: Chances that a move swaps two rooms; that a moved room opens a new row, or a new
#: column (the rest join an existing column).
SWAP_CHANCE = 0.4
NEW_ROW_CHANCE = 0.1
NEW_COLUMN_CHANCE = 0.5


@dataclass(frozen=True)
class Contact:
    """An adjacency demand: room `a` touches one of `partners` along `min_contact`."""

    a: str
    partners: tuple[str, ...]
    min_contact: float


@dataclass(frozen=True)
class Demands:
    """What the rows must honour beyond sizes: contacts and candidate exterior edges."""

    contacts: tuple[Contact, ...]
    edges: dict[str, tuple[Edge, ...]]

    @classmethod
    def of(cls, problem: Problem, domain: Domain) -> Demands:
        contacts = tuple(Contact(adj.a, tuple(adj.partners), adj.min_contact)
                         for adj in problem.adjacency)
        edges = {room.id: tuple(edges_named(problem, domain.edges, room.boundary))
                 for room in problem.rooms if room.boundary}
        return cls(contacts, edges)

    def __bool__(self) -> bool:
        return bool(self.contacts or self.edges)


Column = list[Room]  # south to north
Row = list[Column]  # west to east
Place = tuple[int, int, int, int]  # region, row (south to north), column, index in column


class RowPlan:
    """Rooms in columns, columns in rows, rows stacked in the rectangles of free floor
    (`regions`)."""

    def __init__(self, regions: Sequence[Box], rows: list[list[Row]]) -> None:
        self.regions = list(regions)
        self.rows = rows  # region -> rows
        self.place: dict[str, Place] = {
            room.id: (g, k, c, j)
            for g, region_rows in enumerate(rows)
            for k, row in enumerate(region_rows)
            for c, column in enumerate(row)
            for j, room in enumerate(column)
        }

    def copy(self) -> RowPlan:
        return RowPlan(self.regions, [[[list(col) for col in row] for row in rs]
                                      for rs in self.rows])

    def column_of(self, room: str) -> Column:
        g, k, c, _ = self.place[room]
        return self.rows[g][k][c]

    # Structure: which walls two places can share, and which exterior edges a place can
    # lie on, whatever the sizes.

    def in_one_column(self, a: str, b: str) -> bool:
        """One directly above the other: they share the column's width."""
        ga, ka, ca, ja = self.place[a]
        gb, kb, cb, jb = self.place[b]
        return (ga, ka, ca) == (gb, kb, cb) and abs(ja - jb) == 1

    def side_by_side(self, a: str, b: str) -> bool:
        """In neighbouring columns of one row: they touch where their y-ranges overlap."""
        ga, ka, ca, _ = self.place[a]
        gb, kb, cb, _ = self.place[b]
        return (ga, ka) == (gb, kb) and abs(ca - cb) == 1

    def stacked(self, low: str, high: str) -> bool:
        """`low` tops its column, `high` starts a column of the row just above."""
        ga, ka, _, ja = self.place[low]
        gb, kb, _, jb = self.place[high]
        if ja != len(self.column_of(low)) - 1 or jb != 0:
            return False
        if ga == gb:
            return kb == ka + 1
        a, b = self.regions[ga], self.regions[gb]
        return (ka == len(self.rows[ga]) - 1 and kb == 0
                and abs(a.y1 - b.y0) <= LINE_TOL and min(a.x1, b.x1) > max(a.x0, b.x0))

    def beside(self, west: str, east: str) -> bool:
        """`west` is in the last column of a row ending on its rectangle's east side,
        where `east`'s row starts in the next rectangle."""
        ga, ka, ca, _ = self.place[west]
        gb, _, cb, _ = self.place[east]
        a, b = self.regions[ga], self.regions[gb]
        return (ga != gb and ca == len(self.rows[ga][ka]) - 1 and cb == 0
                and abs(a.x1 - b.x0) <= LINE_TOL and min(a.y1, b.y1) > max(a.y0, b.y0))

    def along_x(self, a: str, b: str) -> bool:
        """Whether a wall between `a` and `b` would run east-west (their x-ranges meet)."""
        return self.in_one_column(a, b) or self.stacked(a, b) or self.stacked(b, a)

    def can_touch(self, a: str, b: str) -> bool:
        return (self.along_x(a, b) or self.side_by_side(a, b)
                or self.beside(a, b) or self.beside(b, a))

    def can_lie_on(self, room: str, edge: Edge) -> bool:
        g, k, c, j = self.place[room]
        region = self.regions[g]
        lo, hi = edge.span
        side: float | None = None
        if edge.horizontal:
            if edge.facing == "south" and k == 0 and j == 0:
                side = region.y0
            elif (edge.facing == "north" and k == len(self.rows[g]) - 1
                  and j == len(self.rows[g][k][c]) - 1):
                side = region.y1
            overlap = min(region.x1, hi) - max(region.x0, lo)
        else:
            if edge.facing == "west" and c == 0:
                side = region.x0
            elif edge.facing == "east" and c == len(self.rows[g][k]) - 1:
                side = region.x1
            overlap = min(region.y1, hi) - max(region.y0, lo)
        return side is not None and abs(side - edge.line) <= LINE_TOL and overlap > LINE_TOL

    def unmet(self, demands: Demands) -> int:
        """Demands no sizes can satisfy in this plan, plus empty rectangles of floor."""
        count = sum(1 for rows in self.rows if not rows)
        for c in demands.contacts:
            if not any(self.can_touch(c.a, p) for p in c.partners):
                count += 1
        for room, edges in demands.edges.items():
            if not any(self.can_lie_on(room, e) for e in edges):
                count += 1
        return count


def estimated_boxes(plan: RowPlan, target: dict[str, tuple[float, float]]) -> dict[str, Box]:
    """Each room's rectangle with the rows of a rectangle of floor equally deep, each
    row's column widths in proportion to their rooms' mean target width and each
    column's room depths in proportion to their target depths."""
    boxes: dict[str, Box] = {}
    for region, rows in zip(plan.regions, plan.rows, strict=True):
        h = region.depth / max(1, len(rows))
        for k, row in enumerate(rows):
            wants = [sum(target[r.id][0] for r in col) / len(col) for col in row]
            scale = region.width / sum(wants)
            x, y_row = region.x0, region.y0 + k * h
            for col, want in zip(row, wants, strict=True):
                w = want * scale
                depth_scale = h / sum(target[r.id][1] for r in col)
                y = y_row
                for room in col:
                    d = target[room.id][1] * depth_scale
                    boxes[room.id] = Box(x, y, x + w, y + d)
                    y += d
                x += w
    return boxes


def size_estimate(boxes: dict[str, Box], target: dict[str, tuple[float, float]]) -> float:
    """E_size (Eq. 6) of the estimated rectangles."""
    return sum((b.width - target[r][0]) ** 2 + (b.depth - target[r][1]) ** 2
               for r, b in boxes.items())


def bounds_misfit(plan: RowPlan) -> float:
    """How far (metres) the rooms' size bounds are from filling the floor: a column whose
    rooms admit no common width, rows whose columns' widths cannot fill them, columns
    whose rooms' depths cannot add up to one row depth, rows that cannot add up to their
    rectangle's depth."""
    misfit = 0.0
    for region, rows in zip(plan.regions, plan.rows, strict=True):
        region_lo = region_hi = 0.0
        for row in rows:
            row_w_lo = row_w_hi = 0.0
            depth_lo, depth_hi = 0.0, math.inf
            for col in row:
                w_lo = max(_lo(r, 0) for r in col)
                w_hi = min(_hi(r, 0) for r in col)
                misfit += max(0.0, w_lo - w_hi)
                row_w_lo += w_lo
                row_w_hi += w_hi
                depth_lo = max(depth_lo, sum(_lo(r, 1) for r in col))
                depth_hi = min(depth_hi, sum(_hi(r, 1) for r in col))
            misfit += max(0.0, row_w_lo - region.width) + max(0.0, region.width - row_w_hi)
            misfit += max(0.0, depth_lo - depth_hi)
            region_lo += depth_lo
            region_hi += depth_hi
        if rows:
            misfit += max(0.0, region_lo - region.depth) + max(0.0, region.depth - region_hi)
    return misfit


def _lo(room: Room, axis: int) -> float:
    return room.min_size[axis] if room.min_size else 0.0


def _hi(room: Room, axis: int) -> float:
    return room.max_size[axis] if room.max_size else math.inf


def position_misfit(plan: RowPlan, boxes: dict[str, Box]) -> float:
    """Metres between each guide point (C_pos, Eq. 8) and its room's estimated
    rectangle; a point outside the room's rectangle of floor counts a kilometre."""
    misfit = 0.0
    for g, rows in enumerate(plan.rows):
        for room in (room for row in rows for col in row for room in col):
            b = boxes[room.id]
            for x, y in room.positions:
                if not plan.regions[g].contains_point(x, y, tol=LINE_TOL):
                    misfit += 1e3
                misfit += max(0.0, b.x0 - x, x - b.x1) + max(0.0, b.y0 - y, y - b.y1)
    return misfit


def demand_misfit(plan: RowPlan, demands: Demands, boxes: dict[str, Box]) -> float:
    """Metres the estimated rectangles miss their demands by, where the structure lets
    them hold: contact short of `min_contact`, a side running off its exterior edge."""
    misfit = 0.0
    for c in demands.contacts:
        shortfalls = [_contact_shortfall(plan, boxes, c.a, p, c.min_contact)
                      for p in c.partners if plan.can_touch(c.a, p)]
        misfit += min(shortfalls, default=0.0)
    for room, edges in demands.edges.items():
        b = boxes[room]
        outside = [max(0.0, e.span[0] - (b.x0 if e.horizontal else b.y0))
                   + max(0.0, (b.x1 if e.horizontal else b.y1) - e.span[1])
                   for e in edges if plan.can_lie_on(room, e)]
        misfit += min(outside, default=0.0)
    return misfit


def _contact_shortfall(plan: RowPlan, boxes: dict[str, Box], a: str, b: str,
                       contact: float) -> float:
    p, q = boxes[a], boxes[b]
    if plan.along_x(a, b):
        overlap = min(p.x1, q.x1) - max(p.x0, q.x0)
    else:
        overlap = min(p.y1, q.y1) - max(p.y0, q.y0)
    return max(0.0, contact - overlap)


def energy(plan: RowPlan, demands: Demands, target: dict[str, tuple[float, float]]) -> float:
    boxes = estimated_boxes(plan, target)
    return (DEMAND_WEIGHT * plan.unmet(demands)
            + MISFIT_WEIGHT * (bounds_misfit(plan) + position_misfit(plan, boxes)
                               + demand_misfit(plan, demands, boxes))
            + size_estimate(boxes, target))


def sizeable(plan: RowPlan, demands: Demands) -> bool:
    """Every demand can hold and the size bounds can fill the floor: worth a QP."""
    return plan.unmet(demands) == 0 and bounds_misfit(plan) <= LINE_TOL


def anneal_rows(
    start: RowPlan, demands: Demands, target: dict[str, tuple[float, float]],
    *, rng: random.Random, deadline: float, moves: int,
) -> RowPlan:
    """Simulated annealing over plans: move a room to another place (into a column,
    into a new column, now and then into a new row) or swap two rooms; `moves` moves
    (fewer at the deadline), cooling from a temperature that crosses a few decimetres of
    misfit to one where only E_size still moves; returns the lowest-energy plan seen."""
    rooms = [room for rows in start.rows for row in rows for col in row for room in col]
    current, e_current = start, energy(start, demands, target)
    best, e_best = current, e_current
    temperature = HOT * MISFIT_WEIGHT
    cooling = (COLD / HOT / MISFIT_WEIGHT) ** (1 / max(1, moves))
    for step in range(moves):
        if step % 100 == 99 and time.monotonic() >= deadline:
            break
        candidate = _moved(current, rooms, rng)
        e_candidate = energy(candidate, demands, target)
        delta = e_candidate - e_current
        if delta <= 0 or rng.random() < math.exp(-delta / temperature):
            current, e_current = candidate, e_candidate
            if e_current < e_best - 1e-9:
                best, e_best = current, e_current
        temperature *= cooling
    return best


def _moved(plan: RowPlan, rooms: list[Room], rng: random.Random) -> RowPlan:
    new = plan.copy()
    room = rng.choice(rooms)
    g, k, c, j = new.place[room.id]
    if rng.random() < SWAP_CHANCE:
        other = rng.choice(rooms)
        g2, k2, c2, j2 = new.place[other.id]
        new.rows[g][k][c][j], new.rows[g2][k2][c2][j2] = other, room
        return RowPlan(new.regions, new.rows)
    # Take the room out, dropping a column or row it leaves empty.
    del new.rows[g][k][c][j]
    if not new.rows[g][k][c]:
        del new.rows[g][k][c]
        if not new.rows[g][k]:
            del new.rows[g][k]
    rows = new.rows[rng.randrange(len(new.regions))]
    where = rng.random()
    if not rows or where < NEW_ROW_CHANCE:
        rows.insert(rng.randint(0, len(rows)), [[room]])
    else:
        row = rows[rng.randrange(len(rows))]
        if where < NEW_ROW_CHANCE + NEW_COLUMN_CHANCE:
            row.insert(rng.randint(0, len(row)), [room])
        else:
            col = row[rng.randrange(len(row))]
            col.insert(rng.randint(0, len(col)), room)
    return RowPlan(new.regions, new.rows)


def kicked(plan: RowPlan, rng: random.Random, *, moves: int) -> RowPlan:
    """The plan after a few random moves: a fresh start for the next annealing."""
    rooms = [room for rows in plan.rows for row in rows for col in row for room in col]
    for _ in range(moves):
        plan = _moved(plan, rooms, rng)
    return plan
