"""A simulated-annealing layout search, the stochastic baseline of the paper's Sec. 6
comparison (the non-parallel version of Merrell, Schkufza and Koltun 2010).

Every room is one rectangle. The search starts from equal rectangles tiling the
domain's bounding box (rooms dealt to them in a seeded random order) and repeats one
random move at a time:

- swap: two rooms exchange their rectangles;
- slide a wall: one side of a room moves, by a random step, onto an existing line
  nearby (the outline, an obstacle, another room's wall, a guide point: how walls
  come to be exactly shared), or to where the room's extent equals its minimum,
  maximum or target size; sometimes the rooms whose facing wall lies on the same
  line move with it, so a shared wall slides as one;
- resize: width and depth change about a random corner or the centre, sometimes
  straight to the room's target size;
- translate: the room moves, sometimes so that one of its sides lands on a line.

The energy is Eq. 12 as the MIQP states it (lambda_cover * uncovered area +
lambda_size * sum of (w - w*)^2 + (d - d*)^2) plus penalties for every violated
constraint: overlap area, area outside the free domain, size bounds, aspect ratio,
distance to guide points, distance to a named exterior edge, and for each adjacency
the distance between the walls plus the shortfall of the shared length. A move is
accepted by the Metropolis rule at temperature T, which falls geometrically with
elapsed time from T0 (set from the uphill moves of a random sample, so about half of
them are accepted at the start) to T0 * `T_END_RATIO` at the time limit.

The energy is updated incrementally (only the moved rooms' terms), in numpy, so the
search makes tens of thousands of moves per second on small problems.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from floorplan.models import Problem
from floorplan.solver.geometry import Box, Domain

#: Penalty per m^2 of overlap or outside area, relative to lambda_cover.
AREA_PENALTY = 10.0
#: Penalty per metre of size, ratio, position, boundary or adjacency violation, per
#: metre of the rooms' typical side (so the weights scale with the problem).
LENGTH_PENALTY = 10.0
#: Final temperature as a share of the initial one.
T_END_RATIO = 1e-5
#: Random steps are rounded to this grid (metres).
GRID = 0.05
#: Contact a room keeps with a named exterior edge (metres, at most its own side).
BOUNDARY_CONTACT = 1.0
#: Move probabilities: swap, slide a wall, resize, translate.
MOVES = (("swap", 0.08), ("slide", 0.5), ("resize", 0.17), ("translate", 0.25))


@dataclass
class Snapshot:
    """The best layout at some moment of the search."""

    elapsed: float
    rooms: dict[str, list[Box]]
    energy: float


@dataclass
class AnnealResult:
    rooms: dict[str, list[Box]]
    energy: float
    seconds: float
    moves: int
    accepted: int
    last_improvement: float
    snapshots: list[Snapshot] = field(default_factory=list)


@dataclass(frozen=True)
class _Edge:
    horizontal: bool
    line: float
    lo: float
    hi: float
    low_side: bool  # the room's low side (x0 or y0) lies on the edge: south or west facing


@dataclass(frozen=True)
class _Contact:
    a: int
    partners: tuple[int, ...]
    length: float


class Annealer:
    """One seeded annealing run on a problem."""

    def __init__(self, problem: Problem, domain: Domain, *, seed: int = 0) -> None:
        self.problem = problem
        self.domain = domain
        self.rng = random.Random(seed)
        rooms = problem.rooms
        n = self.n = len(rooms)
        self.ids = [r.id for r in rooms]
        bb = domain.bbox
        self.bbox = bb
        self.lc = problem.weights.cover
        self.ls = problem.weights.size
        self.free_area = domain.area
        self.min_w = [r.min_size[0] if r.min_size else 0.0 for r in rooms]
        self.min_d = [r.min_size[1] if r.min_size else 0.0 for r in rooms]
        self.max_w = [min(r.max_size[0], bb.width) if r.max_size else bb.width for r in rooms]
        self.max_d = [min(r.max_size[1], bb.depth) if r.max_size else bb.depth for r in rooms]
        self.targets = [r.target_size for r in rooms]
        self.ratios = [r.aspect_ratio for r in rooms]
        self.positions = [list(r.positions) for r in rooms]
        index = {room_id: k for k, room_id in enumerate(self.ids)}
        self.edges: list[list[_Edge]] = []
        for r in rooms:
            named = [e for e in domain.edges
                     if any(e.index == k or e.facing == k for k in r.boundary)]
            self.edges.append([_Edge(e.horizontal, e.line, *e.span,
                                     low_side=e.facing in ("south", "west")) for e in named])
        self.contacts = [_Contact(index[a.a], tuple(index[p] for p in a.partners), a.min_contact)
                         for a in problem.adjacency]
        self.contacts_of: list[list[int]] = [[] for _ in range(n)]
        for k, c in enumerate(self.contacts):
            for i in {c.a, *c.partners}:
                self.contacts_of[i].append(k)
        blocked = domain.blocked
        self.blocked = [(b.x0, b.y0, b.x1, b.y1) for b in blocked]
        typical = math.sqrt(self.free_area / max(n, 1))
        self.p_area = AREA_PENALTY * max(self.lc, 1.0)
        self.p_len = LENGTH_PENALTY * typical * max(self.lc, 1.0)
        xs = {bb.x0, bb.x1, *(b.x0 for b in blocked), *(b.x1 for b in blocked)}
        ys = {bb.y0, bb.y1, *(b.y0 for b in blocked), *(b.y1 for b in blocked)}
        for pts in self.positions:
            xs.update(p[0] for p in pts)
            ys.update(p[1] for p in pts)
        self.fixed_lines = (sorted(xs), sorted(ys))
        self.step0 = 0.5 * typical
        self._initial_state()

    # The state and its energy.

    def _initial_state(self) -> None:
        """Equal rectangles tiling the bounding box, rooms dealt in a random order."""
        n, bb = self.n, self.bbox
        cols = max(1, round(math.sqrt(n * bb.width / bb.depth)))
        rows = math.ceil(n / cols)
        cells = [(c, r) for r in range(rows) for c in range(cols)]
        self.rng.shuffle(cells)
        w, d = bb.width / cols, bb.depth / rows
        self.x0 = np.array([bb.x0 + c * w for c, _ in cells[:n]])
        self.y0 = np.array([bb.y0 + r * d for _, r in cells[:n]])
        self.x1 = self.x0 + w
        self.y1 = self.y0 + d
        self.unary = np.array([self._unary(i) for i in range(n)])
        self.pairs = np.zeros((n, n))
        for i in range(n):
            self.pairs[i] = self._overlap_row(i)
        self.adj = np.array([self._contact(c) for c in self.contacts])
        self.energy = self._total()

    def _total(self) -> float:
        return float(self.lc * self.free_area + self.unary.sum() + 0.5 * self.pairs.sum()
                     + self.adj.sum())

    def _inside_area(self, i: int) -> tuple[float, float]:
        """(area inside the free domain, area outside it) of room i."""
        x0, y0, x1, y1 = (float(self.x0[i]), float(self.y0[i]), float(self.x1[i]),
                          float(self.y1[i]))
        area = (x1 - x0) * (y1 - y0)
        bb = self.bbox
        in_box = (max(0.0, min(x1, bb.x1) - max(x0, bb.x0))
                  * max(0.0, min(y1, bb.y1) - max(y0, bb.y0)))
        # Blocked boxes are few and disjoint: a plain loop beats numpy on so few.
        for bx0, by0, bx1, by1 in self.blocked:
            ox = min(x1, bx1) - max(x0, bx0)
            if ox > 0:
                oy = min(y1, by1) - max(y0, by0)
                if oy > 0:
                    in_box -= ox * oy
        return in_box, area - in_box

    def _unary(self, i: int) -> float:
        """Room i's own terms: -lambda_cover * covered area, E_size, and the penalties
        of its size, ratio, position, boundary and outside area."""
        x0, y0, x1, y1 = (float(self.x0[i]), float(self.y0[i]), float(self.x1[i]),
                          float(self.y1[i]))
        w, d = x1 - x0, y1 - y0
        inside, outside = self._inside_area(i)
        e = -self.lc * inside + self.p_area * outside
        t = self.targets[i]
        if t is not None:
            e += self.ls * ((w - t[0]) ** 2 + (d - t[1]) ** 2)
        v = (max(0.0, self.min_w[i] - w) + max(0.0, w - self.max_w[i])
             + max(0.0, self.min_d[i] - d) + max(0.0, d - self.max_d[i]))
        ratio = self.ratios[i]
        if ratio is not None:
            long, short = max(w, d), min(w, d)
            v += max(0.0, ratio[0] * short - long) + max(0.0, long - ratio[1] * short)
        for px, py in self.positions[i]:
            v += max(0.0, x0 - px) + max(0.0, px - x1) + max(0.0, y0 - py) + max(0.0, py - y1)
        if self.edges[i]:
            v += min(self._edge_gap(i, edge) for edge in self.edges[i])
        return e + self.p_len * v

    def _edge_gap(self, i: int, e: _Edge) -> float:
        x0, y0, x1, y1 = self.x0[i], self.y0[i], self.x1[i], self.y1[i]
        if e.horizontal:
            side, a, b = (y0 if e.low_side else y1), x0, x1
        else:
            side, a, b = (x0 if e.low_side else x1), y0, y1
        along = max(0.0, min(b, e.hi) - max(a, e.lo))
        return abs(side - e.line) + max(0.0, min(BOUNDARY_CONTACT, b - a) - along)

    def _overlap_row(self, i: int) -> np.ndarray:
        """(lambda_cover + overlap penalty) * overlap area of room i with every room."""
        ox = np.minimum(self.x1[i], self.x1) - np.maximum(self.x0[i], self.x0)
        oy = np.minimum(self.y1[i], self.y1) - np.maximum(self.y0[i], self.y0)
        row = (self.lc + self.p_area) * np.maximum(ox, 0.0) * np.maximum(oy, 0.0)
        row[i] = 0.0
        return row

    def _contact(self, c: _Contact) -> float:
        """Adjacency penalty: wall distance plus shared-length shortfall, best partner."""
        a = c.a
        best = math.inf
        for b in c.partners:
            xo = min(self.x1[a], self.x1[b]) - max(self.x0[a], self.x0[b])
            yo = min(self.y1[a], self.y1[b]) - max(self.y0[a], self.y0[b])
            side_by_side = (min(abs(self.x1[a] - self.x0[b]), abs(self.x1[b] - self.x0[a]))
                            + max(0.0, c.length - yo))
            stacked = (min(abs(self.y1[a] - self.y0[b]), abs(self.y1[b] - self.y0[a]))
                       + max(0.0, c.length - xo))
            best = min(best, side_by_side, stacked)
        return self.p_len * best

    def _contribution(self, moved: list[int], rows: np.ndarray, contacts: list[int]) -> float:
        block = rows[:, moved].sum()
        return float(self.unary[moved].sum() + rows.sum() - 0.5 * block
                     + self.adj[contacts].sum())

    # Moves.

    def _snap_line(self, axis: int, near: float, radius: float, exclude: int) -> float | None:
        """A random existing line within `radius` of `near` on x (axis 0) or y (1)."""
        fixed = self.fixed_lines[axis]
        if axis == 0:
            walls = np.concatenate([self.x0, self.x1])
        else:
            walls = np.concatenate([self.y0, self.y1])
        mask = np.abs(walls - near) <= radius
        mask[exclude] = mask[exclude + self.n] = False
        candidates = [*walls[mask].tolist(), *(v for v in fixed if abs(v - near) <= radius)]
        candidates = [v for v in candidates if abs(v - near) > 1e-12]
        return self.rng.choice(candidates) if candidates else None

    def _step(self, scale: float) -> float:
        return round(self.rng.gauss(0.0, scale) / GRID) * GRID

    def _propose(self, scale: float) -> list[int] | None:
        """Apply a random move in place; returns the rooms it changed (None: no move)."""
        rng = self.rng
        kind = rng.choices([m for m, _ in MOVES], weights=[p for _, p in MOVES])[0]
        i = rng.randrange(self.n)
        if kind == "swap":
            return self._swap(i)
        if kind == "slide":
            return self._slide(i, scale)
        if kind == "resize":
            return self._resize(i, scale)
        return self._translate(i, scale)

    def _swap(self, i: int) -> list[int] | None:
        """Room i trades places with another."""
        rng, n = self.rng, self.n
        if n < 2:
            return None
        j = rng.randrange(n - 1)
        j += j >= i
        for arr in (self.x0, self.y0, self.x1, self.y1):
            arr[i], arr[j] = arr[j], arr[i]
        return [i, j]

    def _slide(self, i: int, scale: float) -> list[int] | None:
        """One side of room i moves (onto a line, to a bound, or by a step), sometimes
        with the rooms sharing that wall."""
        rng = self.rng
        axis, high = rng.randrange(2), rng.random() < 0.5
        lo_arr, hi_arr = (self.x0, self.x1) if axis == 0 else (self.y0, self.y1)
        arr = hi_arr if high else lo_arr
        old = float(arr[i])
        pick = rng.random()
        new = None
        if pick < 0.4:
            new = self._snap_line(axis, old, 3 * scale, i)
        elif pick < 0.6:
            # The side lands where the room's extent meets one of its own bounds.
            sizes = [self.min_w[i], self.max_w[i]] if axis == 0 else [
                self.min_d[i], self.max_d[i]]
            if self.targets[i] is not None:
                sizes.append(self.targets[i][axis])
            size = float(rng.choice(sizes))
            new = lo_arr[i] + size if high else hi_arr[i] - size
        if new is None:
            new = old + self._step(scale)
        if (high and new <= lo_arr[i] + GRID) or (not high and new >= hi_arr[i] - GRID):
            return None
        moved = [i]
        if rng.random() < 0.3:
            # The shared wall: rooms whose facing side is on the same line and overlap
            # room i along it move with it.
            other_lo, other_hi = (self.y0, self.y1) if axis == 0 else (self.x0, self.x1)
            facing = lo_arr if high else hi_arr
            along = (np.minimum(other_hi[i], other_hi) - np.maximum(other_lo[i], other_lo)
                     > 0)
            near = np.abs(facing - old) < 1e-9
            for j in np.flatnonzero(near & along).tolist():
                if j == i:
                    continue
                opposite = hi_arr[j] if high else lo_arr[j]
                if (high and new >= opposite - GRID) or (not high and new <= opposite + GRID):
                    return None
                moved.append(j)
        arr[i] = new
        for j in moved[1:]:
            (lo_arr if high else hi_arr)[j] = new
        return moved

    def _resize(self, i: int, scale: float) -> list[int] | None:
        """Room i takes its target size or a step from its size, around a random anchor."""
        rng = self.rng
        w, d = self.x1[i] - self.x0[i], self.y1[i] - self.y0[i]
        t = self.targets[i]
        if t is not None and rng.random() < 0.2:
            nw, nd = t
        else:
            nw, nd = w + self._step(scale), d + self._step(scale)
        if nw < GRID or nd < GRID:
            return None
        ax, ay = rng.choice((0.0, 0.5, 1.0)), rng.choice((0.0, 0.5, 1.0))
        self.x0[i] += ax * (w - nw)
        self.y0[i] += ay * (d - nd)
        self.x1[i] = self.x0[i] + nw
        self.y1[i] = self.y0[i] + nd
        return [i]

    def _translate(self, i: int, scale: float) -> list[int] | None:
        """Room i moves by a step, or so that one side lands on a nearby line."""
        rng = self.rng
        dx, dy = self._step(scale), self._step(scale)
        if rng.random() < 0.5:
            axis, high = rng.randrange(2), rng.random() < 0.5
            lo_arr, hi_arr = (self.x0, self.x1) if axis == 0 else (self.y0, self.y1)
            old = float((hi_arr if high else lo_arr)[i])
            line = self._snap_line(axis, old, 3 * scale, i)
            if line is not None:
                if axis == 0:
                    dx, dy = line - old, 0.0
                else:
                    dx, dy = 0.0, line - old
        if dx == 0 and dy == 0:
            return None
        self.x0[i] += dx
        self.x1[i] += dx
        self.y0[i] += dy
        self.y1[i] += dy
        return [i]

    # The search.

    def _try(self, scale: float, temperature: float | None) -> tuple[float, bool] | None:
        """Propose a move and accept or undo it (never accepted without a temperature);
        returns its energy change and whether it was accepted, None when no move was
        made."""
        backup = (self.x0.copy(), self.y0.copy(), self.x1.copy(), self.y1.copy())
        moved = self._propose(scale)
        if moved is None:
            return None
        contacts = sorted({k for i in moved for k in self.contacts_of[i]})
        old = self._contribution(moved, self.pairs[moved], contacts)
        new_unary = np.array([self._unary(i) for i in moved])
        new_rows = np.stack([self._overlap_row(i) for i in moved])
        new_adj = np.array([self._contact(self.contacts[k]) for k in contacts])
        block = new_rows[:, moved].sum()
        new = float(new_unary.sum() + new_rows.sum() - 0.5 * block + new_adj.sum())
        delta = new - old
        accept = temperature is not None and (
            delta <= 0 or self.rng.random() < math.exp(-delta / temperature))
        if accept:
            self.unary[moved] = new_unary
            self.pairs[moved, :] = new_rows
            self.pairs[:, moved] = new_rows.T
            self.adj[contacts] = new_adj
            self.energy += delta
        else:
            self.x0, self.y0, self.x1, self.y1 = backup
        return delta, accept

    def _rooms(self, state: tuple[np.ndarray, ...]) -> dict[str, list[Box]]:
        x0, y0, x1, y1 = state
        return {room_id: [Box(float(x0[k]), float(y0[k]), float(x1[k]), float(y1[k]))]
                for k, room_id in enumerate(self.ids)}

    def run(
        self,
        time_limit: float,
        *,
        snapshot_every: float = 0.1,
        should_stop: Callable[[], bool] | None = None,
    ) -> AnnealResult:
        """Anneal for `time_limit` seconds; the best layout found, with snapshots of the
        best layout taken every `snapshot_every` seconds when it has changed."""
        started = time.monotonic()
        # T0 from a sample of uphill moves (none accepted: temperature None).
        sample = [self._try(self.step0, None) for _ in range(200)]
        uphill = [t[0] for t in sample if t is not None and t[0] > 0]
        t0 = float(np.median(uphill)) / math.log(2) if uphill else 1.0
        best_energy = self.energy
        best = (self.x0.copy(), self.y0.copy(), self.x1.copy(), self.y1.copy())
        snapshots: list[Snapshot] = []
        last_snapshot = -math.inf
        best_changed = True
        last_improvement = 0.0
        moves = accepted = 0
        elapsed = time.monotonic() - started
        temperature, scale = t0, self.step0
        while elapsed < time_limit:
            for _ in range(50):
                outcome = self._try(scale, temperature)
                if outcome is None:
                    continue
                moves += 1
                accepted += outcome[1]
                if self.energy < best_energy - 1e-12:
                    best_energy = self.energy
                    best = (self.x0.copy(), self.y0.copy(), self.x1.copy(), self.y1.copy())
                    best_changed = True
                    last_improvement = elapsed
            elapsed = time.monotonic() - started
            if best_changed and elapsed - last_snapshot >= snapshot_every:
                snapshots.append(Snapshot(elapsed, self._rooms(best), best_energy))
                last_snapshot, best_changed = elapsed, False
            if should_stop is not None and should_stop():
                break
            frac = min(1.0, elapsed / time_limit)
            temperature = t0 * T_END_RATIO ** frac
            scale = max(GRID, self.step0 * (1 - frac) ** 2)
        self.x0, self.y0, self.x1, self.y1 = best
        rooms = self._rooms(best)
        seconds = time.monotonic() - started
        if best_changed:
            snapshots.append(Snapshot(seconds, rooms, best_energy))
        return AnnealResult(rooms, best_energy, seconds, moves, accepted, last_improvement,
                            snapshots)


def anneal(
    problem: Problem,
    domain: Domain,
    *,
    time_limit: float,
    seed: int = 0,
    snapshot_every: float = 0.1,
) -> AnnealResult:
    """One seeded annealing run (see the module docstring)."""
    return Annealer(problem, domain, seed=seed).run(time_limit, snapshot_every=snapshot_every)
