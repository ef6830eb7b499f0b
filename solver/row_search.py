"""Rows of rooms for problems with demands that couple rooms (adjacency, Eq. 10-11) or
tie them to the outline (boundary, Eq. 9): which room goes in which row, in what order.

A row plan fixes every relation the MIQP's binaries would choose: two rooms side by
side in a row share a wall as tall as the row; rooms of stacked rows share the line
between the rows and touch where their x-ranges overlap; the bottom row of a rectangle
of free floor lies on its south side, the first room of a row on its west side. So
whether a demand *can* hold in a plan is a question of structure, answered here without
any solver, and the annealing below looks for a plan where every demand can; the convex
QP of `solver.slicing` then sets the sizes, with each demand a linear constraint.
"""

from __future__ import annotations

import itertools
import math
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass

from models import Problem, Room
from solver.geometry import Box, Domain, Edge, edges_named

#: Touching tolerance for lines of the floor's rectangles, metres.
LINE_TOL = 1e-6
#: Weight of one demand that cannot hold against the E_size estimate (m²): any plan
#: where every demand can hold beats any plan where one cannot.
DEMAND_WEIGHT = 1e4
#: Weight of a metre of size bounds that cannot fill the floor, or of a guide point
#: away from its room's row.
MISFIT_WEIGHT = 1e3
#: Chance that a move opens a new row instead of joining an existing one.
NEW_ROW_CHANCE = 0.1


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


class RowPlan:
    """Rooms in rows, rows stacked in the rectangles of free floor (`regions`),
    bottom to top; a room's place is (region, row, index along the row, west to east)."""

    def __init__(self, regions: Sequence[Box], rows: list[list[list[Room]]]) -> None:
        self.regions = list(regions)
        self.rows = rows  # region -> rows bottom to top -> rooms west to east
        self.place: dict[str, tuple[int, int, int]] = {
            room.id: (g, k, i)
            for g, region_rows in enumerate(rows)
            for k, row in enumerate(region_rows)
            for i, room in enumerate(row)
        }

    def copy(self) -> RowPlan:
        return RowPlan(self.regions, [[list(row) for row in rs] for rs in self.rows])

    # Structure: which walls two places can share, and which exterior edges a place can
    # lie on, whatever the sizes.

    def in_one_row(self, a: str, b: str) -> bool:
        ga, ka, ia = self.place[a]
        gb, kb, ib = self.place[b]
        return (ga, ka) == (gb, kb) and abs(ia - ib) == 1

    def stacked(self, low: str, high: str) -> bool:
        """The top of `low`'s row is the bottom of `high`'s row."""
        ga, ka, _ = self.place[low]
        gb, kb, _ = self.place[high]
        if ga == gb:
            return kb == ka + 1
        a, b = self.regions[ga], self.regions[gb]
        return (ka == len(self.rows[ga]) - 1 and kb == 0
                and abs(a.y1 - b.y0) <= LINE_TOL and min(a.x1, b.x1) > max(a.x0, b.x0))

    def beside(self, west: str, east: str) -> bool:
        """`west` ends its row on its region's east side, where `east` starts its row in
        the next region."""
        ga, ka, ia = self.place[west]
        gb, _kb, ib = self.place[east]
        a, b = self.regions[ga], self.regions[gb]
        return (ga != gb and ia == len(self.rows[ga][ka]) - 1 and ib == 0
                and abs(a.x1 - b.x0) <= LINE_TOL and min(a.y1, b.y1) > max(a.y0, b.y0))

    def can_touch(self, a: str, b: str) -> bool:
        return (self.in_one_row(a, b) or self.stacked(a, b) or self.stacked(b, a)
                or self.beside(a, b) or self.beside(b, a))

    def can_lie_on(self, room: str, edge: Edge) -> bool:
        g, k, i = self.place[room]
        region = self.regions[g]
        lo, hi = edge.span
        if edge.horizontal:
            side = (region.y0 if k == 0 else None) if edge.facing == "south" else (
                region.y1 if k == len(self.rows[g]) - 1 else None)
            overlap = min(region.x1, hi) - max(region.x0, lo)
        else:
            last = len(self.rows[g][k]) - 1
            side = (region.x0 if i == 0 else None) if edge.facing == "west" else (
                region.x1 if i == last else None)
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


def size_estimate(plan: RowPlan, target: dict[str, tuple[float, float]]) -> float:
    """E_size (Eq. 6) with the rows of a rectangle equally deep and each row's width
    misfit spread evenly over its rooms: what the QP would roughly make of the plan."""
    total = 0.0
    for region, rows in zip(plan.regions, plan.rows, strict=True):
        if not rows:
            continue
        h = region.depth / len(rows)
        for row in rows:
            n = len(row)
            misfit = sum(target[r.id][0] for r in row) - region.width
            total += misfit * misfit / n + sum((h - target[r.id][1]) ** 2 for r in row)
    return total


def bounds_misfit(plan: RowPlan) -> float:
    """How far (metres) the rows' size bounds are from filling their rectangles:
    a row whose rooms' minimum widths overflow it, or whose maximum widths cannot fill
    it, or whose rooms admit no common depth."""
    misfit = 0.0
    for region, rows in zip(plan.regions, plan.rows, strict=True):
        depth_lo = depth_hi = 0.0
        for row in rows:
            w_lo = sum(r.min_size[0] if r.min_size else 0.0 for r in row)
            w_hi = sum(r.max_size[0] if r.max_size else math.inf for r in row)
            d_lo = max((r.min_size[1] if r.min_size else 0.0) for r in row)
            d_hi = min((r.max_size[1] if r.max_size else math.inf) for r in row)
            misfit += max(0.0, w_lo - region.width) + max(0.0, region.width - w_hi)
            misfit += max(0.0, d_lo - d_hi)
            depth_lo += d_lo
            depth_hi += d_hi
        if rows:
            misfit += max(0.0, depth_lo - region.depth) + max(0.0, region.depth - depth_hi)
    return misfit


def position_misfit(plan: RowPlan) -> float:
    """Metres between each guide point (C_pos, Eq. 8) and the band its room's row would
    have with the rows of its rectangle equally deep."""
    misfit = 0.0
    for g, rows in enumerate(plan.rows):
        region = plan.regions[g]
        if not rows:
            continue
        h = region.depth / len(rows)
        for k, row in enumerate(rows):
            for room in row:
                for x, y in room.positions:
                    if not region.contains_point(x, y, tol=LINE_TOL):
                        misfit += 1e3
                    band_lo, band_hi = region.y0 + k * h, region.y0 + (k + 1) * h
                    misfit += max(0.0, band_lo - y) + max(0.0, y - band_hi)
        for row in rows:
            # Guide points must come west to east in the row's order.
            xs = [min(x for x, _ in r.positions) for r in row if r.positions]
            misfit += sum(max(0.0, a - b) for a, b in itertools.pairwise(xs))
    return misfit


def estimated_boxes(plan: RowPlan, target: dict[str, tuple[float, float]]) -> dict[str, Box]:
    """Each room's rectangle with the rows of a rectangle of floor equally deep and each
    row's widths in proportion to its rooms' target widths."""
    boxes: dict[str, Box] = {}
    for region, rows in zip(plan.regions, plan.rows, strict=True):
        h = region.depth / max(1, len(rows))
        for k, row in enumerate(rows):
            scale = region.width / sum(target[r.id][0] for r in row)
            x = region.x0
            for room in row:
                w = target[room.id][0] * scale
                boxes[room.id] = Box(x, region.y0 + k * h, x + w, region.y0 + (k + 1) * h)
                x += w
    return boxes


def demand_misfit(plan: RowPlan, demands: Demands, boxes: dict[str, Box]) -> float:
    """Metres the estimated rectangles miss their demands by, where the structure lets
    them hold: contact short of `min_contact` between stacked rows (their order along
    the rows decides it) or beside, a side running off its exterior edge."""
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
    if plan.in_one_row(a, b):
        return 0.0
    p, q = boxes[a], boxes[b]
    if plan.stacked(a, b) or plan.stacked(b, a):
        overlap = min(p.x1, q.x1) - max(p.x0, q.x0)
    else:
        overlap = min(p.y1, q.y1) - max(p.y0, q.y0)
    return max(0.0, contact - overlap)


def energy(plan: RowPlan, demands: Demands, target: dict[str, tuple[float, float]]) -> float:
    boxes = estimated_boxes(plan, target)
    return (DEMAND_WEIGHT * plan.unmet(demands)
            + MISFIT_WEIGHT * (bounds_misfit(plan) + position_misfit(plan)
                               + demand_misfit(plan, demands, boxes))
            + size_estimate(plan, target))


def sizeable(plan: RowPlan, demands: Demands) -> bool:
    """Every demand can hold and the rows' bounds can fill the floor: worth a QP."""
    return (plan.unmet(demands) == 0 and bounds_misfit(plan) <= LINE_TOL
            and position_misfit(plan) <= LINE_TOL)


def anneal_rows(
    start: RowPlan, demands: Demands, target: dict[str, tuple[float, float]],
    *, rng: random.Random, deadline: float, moves: int,
) -> RowPlan:
    """Simulated annealing over plans: move a room to another place (now and then into a
    new row of its own) or swap two rooms; returns the lowest-energy plan seen once
    `moves` moves in a row found none better (or at the deadline)."""
    rooms = [room for rows in start.rows for row in rows for room in row]
    current, e_current = start, energy(start, demands, target)
    best, e_best = current, e_current
    # Hot enough at first to accept a move that worsens E_size by a room's share.
    temperature = max(1.0, size_estimate(start, target) / max(1, len(rooms)))
    cooling = 0.01 ** (1 / max(1, moves))  # a hundredth after `moves` moves
    since_best = 0
    while since_best < moves:
        if since_best % 200 == 199 and time.monotonic() >= deadline:
            break
        candidate = _moved(current, rooms, rng)
        e_candidate = energy(candidate, demands, target)
        delta = e_candidate - e_current
        if delta <= 0 or rng.random() < math.exp(-delta / temperature):
            current, e_current = candidate, e_candidate
            if e_current < e_best - 1e-9:
                best, e_best, since_best = current, e_current, 0
                continue
        since_best += 1
        temperature *= cooling
    return best


def _moved(plan: RowPlan, rooms: list[Room], rng: random.Random) -> RowPlan:
    new = plan.copy()
    room = rng.choice(rooms)
    g, k, i = new.place[room.id]
    if rng.random() < 0.4:
        other = rng.choice(rooms)
        g2, k2, i2 = new.place[other.id]
        new.rows[g][k][i], new.rows[g2][k2][i2] = other, room
        return RowPlan(new.regions, new.rows)
    del new.rows[g][k][i]
    if not new.rows[g][k]:
        del new.rows[g][k]
    target_region = rng.randrange(len(new.regions))
    rows = new.rows[target_region]
    if not rows or rng.random() < NEW_ROW_CHANCE:
        rows.insert(rng.randint(0, len(rows)), [room])
    else:
        row = rows[rng.randrange(len(rows))]
        row.insert(rng.randint(0, len(row)), room)
    return RowPlan(new.regions, new.rows)


def kicked(plan: RowPlan, rng: random.Random, *, moves: int) -> RowPlan:
    """The plan after a few random moves: a fresh start for the next annealing."""
    rooms = [room for rows in plan.rows for row in rows for room in row]
    for _ in range(moves):
        plan = _moved(plan, rooms, rng)
    return plan
