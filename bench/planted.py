"""Planted briefs (bench/README.md, "Planted briefs"): a random flat-like plan drawn for
a seed, and the brief a designer would extract from it, so that the optimum of Eq. 12 is
known.

    python -m bench.planted --seed S [S ...] [--rooms N] --out DIR

The plan: a rectangle, L, U or T outline on a 5 cm grid; a guillotine subdivision of its
bounding box into cells; one or two pairs of cells merged into L or T rooms; the whole
cut to the outline (cells outside drop out, cells across it keep their inside, which
makes more L rooms: bench/data/planted/ was drawn this way); types by size and
shape; doors along a spanning tree of the walls the rooms share (at least 0.9 m),
searched breadth first from the room at the entrance. The brief is extracted as
bench/data/README.md ("Planted briefs") states. All geometry is drawn in integer
grid units and converted to metres (2 decimals) only when the brief is written.
"""

from __future__ import annotations

import argparse
import json
import math
import random
import sys
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import shapely
from shapely.geometry import LineString, Point, Polygon, box
from shapely.geometry.polygon import orient

from floorplan.models import Problem
from floorplan.solver.geometry import Box, boundary_edges, rectangles_of

#: The drawing grid, in metres.
UNIT = 0.05
#: Shortest side of a cell, in grid units (1.5 m).
MIN_SIDE = 30
#: Subdivisions tried on one outline before another is drawn.
TRIES_PER_OUTLINE = 50
#: Longest side of a cell over its shortest.
MAX_CELL_RATIO = 4.5
#: Corridors and balconies are at most this wide, in grid units (2 m).
THIN = 40
#: Shortest shared wall that takes a door, in grid units (0.9 m).
DOOR = 18
#: The entrance keeps this far from the ends of its wall, in grid units (0.5 m).
END_GAP = 10
#: The entrance's guide point lies this far inside the room (m).
INSIDE = 0.3
#: Compass sides in the order a brief lists them.
COMPASS = ("north", "east", "south", "west")
GENERATOR = "bench.planted"

Cell = tuple[int, int, int, int]  # x0, y0, x1, y1 in grid units


@dataclass(frozen=True)
class PlantedRoom:
    """One room of the planted plan: its polygon in metres."""

    id: str
    type: str
    polygon: tuple[tuple[float, float], ...]

    @property
    def shape(self) -> Polygon:
        return Polygon(self.polygon)


@dataclass(frozen=True)
class Truth:
    """The planted plan, in the shape of bench/data/planted/NAME.truth.json."""

    name: str
    seed: int | None
    rooms: tuple[PlantedRoom, ...]
    generator: str = GENERATOR

    def boxes(self) -> dict[str, list[Box]]:
        """Room id -> its polygon split into rectangles, as the checker takes a layout."""
        return {r.id: rectangles_of(r.shape) for r in self.rooms}

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "source": {"generator": self.generator, "seed": self.seed},
                "rooms": [{"id": r.id, "type": r.type, "polygon": [list(p) for p in r.polygon],
                           "area": round(r.shape.area, 4)} for r in self.rooms]}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Truth:
        source = data.get("source", {})
        rooms = tuple(PlantedRoom(r["id"], r["type"], tuple((float(x), float(y)) for x, y
                                                           in r["polygon"])) for r in data["rooms"])
        return cls(data["name"], source.get("seed"), rooms, source.get("generator", ""))


@dataclass
class _Plan:
    """A drawn plan in grid units, before extraction."""

    outline: Polygon
    rooms: list[Polygon]
    types: list[str]


def _m(units: float) -> float:
    return round(units * UNIT, 2)


def _floor2(x: float) -> float:
    return math.floor(x * 100 + 1e-6) / 100


def _ceil2(x: float) -> float:
    return math.ceil(x * 100 - 1e-6) / 100


def _notch(w: int, d: int, side: str, start: int, length: int, depth: int) -> Polygon:
    """A notch of `length` along `side` of the w x d box, from `start`, `depth` deep."""
    return {"north": box(start, d - depth, start + length, d),
            "south": box(start, 0, start + length, depth),
            "east": box(w - depth, start, w, start + length),
            "west": box(0, start, depth, start + length)}[side]


def _outline(rng: random.Random, n: int) -> Polygon:
    """A rectangle, L, U or T outline for about `n` rooms, in grid units."""
    kind = rng.choice(("rectangle", "L", "U", "T"))
    fill = {"rectangle": 1.0, "L": 0.8, "U": 0.78, "T": 0.75}[kind]
    area = n * rng.uniform(11.0, 15.0) / fill
    aspect = rng.uniform(1.0, 1.6)
    w = min(max(math.sqrt(area * aspect), 7.0), 17.0)
    d = min(max(area / w, 6.0), 17.0)
    w_u, d_u = round(w / UNIT), round(d / UNIT)
    if rng.random() < 0.5:
        w_u, d_u = d_u, w_u
    outline = box(0, 0, w_u, d_u)
    if kind == "rectangle":
        return outline
    side = rng.choice(COMPASS)
    along, across = (w_u, d_u) if side in ("north", "south") else (d_u, w_u)
    depth = round(across * rng.uniform(0.3, 0.45))
    if kind == "L":
        length = round(along * rng.uniform(0.3, 0.45))
        starts = [rng.choice((0, along - length))]
    elif kind == "U":
        length = round(along * rng.uniform(0.25, 0.4))
        starts = [(along - length) // 2 + round(along * rng.uniform(-0.08, 0.08))]
    else:
        length = round(along * rng.uniform(0.22, 0.32))
        starts = [0, along - length]
    for start in starts:
        outline = outline.difference(_notch(w_u, d_u, side, start, length, depth))
    return orient(outline.simplify(0), 1.0)


def _split(rng: random.Random, cell: Cell, k: int, out: list[Cell]) -> bool:
    """Guillotine-cut `cell` into `k` cells (appended to `out`); False when it cannot."""
    x0, y0, x1, y1 = cell
    w, d = x1 - x0, y1 - y0
    if k == 1:
        out.append(cell)
        return min(w, d) >= MIN_SIDE and max(w, d) <= MAX_CELL_RATIO * min(w, d)
    across_x = w > d if abs(w - d) > 0.15 * max(w, d) else rng.random() < 0.5
    length, other = (w, d) if across_x else (d, w)
    k1 = rng.choice((k // 2, (k + 1) // 2))
    # Each part keeps room for its cells: a side of MIN_SIDE, twice MIN_SIDE² a cell.
    lo = max(MIN_SIDE, math.ceil(k1 * 2 * MIN_SIDE**2 / other))
    hi = length - max(MIN_SIDE, math.ceil((k - k1) * 2 * MIN_SIDE**2 / other))
    if lo > hi:
        return False
    cut = min(max(round(length * k1 / k * rng.uniform(0.8, 1.2)), lo), hi)
    if across_x:
        first, second = (x0, y0, x0 + cut, y1), (x0 + cut, y0, x1, y1)
    else:
        first, second = (x0, y0, x1, y0 + cut), (x0, y0 + cut, x1, y1)
    return _split(rng, first, k1, out) and _split(rng, second, k - k1, out)


def _clipped_rooms(rng: random.Random, outline: Polygon, n: int,
                   pairs: int) -> list[Polygon] | None:
    """`n` rooms: the outline's bounding box cut into cells, `pairs` pairs of them merged,
    then cut to the outline, as a plan drawn on a rectangle is: a cell wholly outside
    drops out, one across the outline keeps its inside part (a smaller rectangle, or an L
    around a corner of the outline). None when that does not give `n` rooms of at least
    half a cell's shortest side."""
    x0, y0, x1, y1 = (round(v) for v in outline.bounds)
    share = outline.area / ((x1 - x0) * (y1 - y0))
    # Tries on the same outline, so that each kind of outline is drawn as often.
    for _ in range(TRIES_PER_OUTLINE):
        cells: list[Cell] = []
        count = round((n + pairs) / share) + rng.choice((-1, 0, 0, 1))
        if count < n + pairs or not _split(rng, (x0, y0, x1, y1), count, cells):
            continue
        merged = _merge(rng, cells, pairs)
        rooms = [] if merged is None else [shape.intersection(outline) for shape in merged]
        rooms = [room for room in rooms if room.area > 0]
        if len(rooms) == n and all(isinstance(room, Polygon) and min(
                room.bounds[2] - room.bounds[0], room.bounds[3] - room.bounds[1])
                >= MIN_SIDE / 2 for room in rooms):
            return [orient(room.simplify(0), 1.0) for room in rooms]
    return None


def _merge_shape(a: Cell, b: Cell) -> bool:
    """True when cells a and b share at least a door's wall and their union is an L or a T
    (not a rectangle, not a Z)."""
    for lo, hi, one, two in ((0, 2, (a[1], a[3]), (b[1], b[3])),
                             (1, 3, (a[0], a[2]), (b[0], b[2]))):
        if a[hi] == b[lo] or b[hi] == a[lo]:
            shared = min(one[1], two[1]) - max(one[0], two[0])
            if shared < DOOR or one == two:
                return False
            aligned = (one[0] == two[0]) + (one[1] == two[1])
            inside = (one[0] <= two[0] and two[1] <= one[1]) or (
                two[0] <= one[0] and one[1] <= two[1])
            return aligned == 1 or inside
    return False


def _merge(rng: random.Random, cells: list[Cell], pairs: int) -> list[Polygon] | None:
    """Rooms: the cells, with `pairs` disjoint pairs of them merged into L or T rooms."""
    candidates = [(i, j) for i in range(len(cells)) for j in range(i + 1, len(cells))
                  if _merge_shape(cells[i], cells[j])]
    rng.shuffle(candidates)
    used: set[int] = set()
    merged: list[Polygon] = []
    for i, j in candidates:
        if len(merged) == pairs:
            break
        if i in used or j in used:
            continue
        used |= {i, j}
        merged.append(shapely.union(box(*cells[i]), box(*cells[j])).simplify(0))
    if len(merged) < pairs:
        return None
    return merged + [box(*c) for k, c in enumerate(cells) if k not in used]


def _types(rooms: list[Polygon], outline: Polygon) -> list[str]:
    """Largest -> living; long thin -> corridor; thin on the facade -> balcony; the
    smallest -> bathroom (and wc, a second bathroom in large flats); the one nearest
    11 m^2 -> kitchen; the rest bedrooms."""
    n = len(rooms)
    types = ["bedroom"] * n
    order = sorted(range(n), key=lambda i: rooms[i].area)
    living = order[-1]
    types[living] = "living"
    free = [i for i in order if i != living]

    def side(i: int) -> tuple[float, float]:
        x0, y0, x1, y1 = rooms[i].bounds
        return min(x1 - x0, y1 - y0), max(x1 - x0, y1 - y0)

    def take(kind: str, chosen: list[int]) -> None:
        for i in chosen:
            types[i] = kind
            free.remove(i)

    take("corridor", [i for i in free if side(i)[0] <= THIN and side(i)[1] >= 2.8 * side(i)[0]][:2])
    take("balcony", [i for i in free if side(i)[0] <= THIN and rooms[i].area == box(
        *rooms[i].bounds).area and _shared(rooms[i], outline) >= 0.95 * side(i)[1]][:1])
    wet = ["bathroom", "wc"] + (["bathroom"] if n >= 10 else [])
    for kind, i in zip(wet, list(free[: len(wet) if n >= 7 else 1]), strict=False):
        take(kind, [i])
    if free:
        target = 11.0 / UNIT**2
        take("kitchen", [min(free, key=lambda i: abs(rooms[i].area - target))])
    return types


def _shared(a: Polygon, b: Polygon) -> float:
    """The length of wall `a` and `b` share (b the outline: a's facade)."""
    return float(a.boundary.intersection(b.boundary).length)


def _doors(rooms: list[Polygon], start: int) -> list[tuple[int, int, float]] | None:
    """A spanning tree of the walls shared over at least `DOOR`, breadth first from
    `start` (neighbours by longest wall first): (from, to, wall length) per door."""
    seen, queue, doors = {start}, deque([start]), []
    while queue:
        i = queue.popleft()
        walls = [(j, _shared(rooms[i], rooms[j])) for j in range(len(rooms)) if j not in seen]
        for j, wall in sorted(walls, key=lambda jw: -jw[1]):
            if wall >= DOOR and j not in seen:
                seen.add(j)
                queue.append(j)
                doors.append((i, j, wall))
    return doors if len(seen) == len(rooms) else None


def _entrance(rng: random.Random, room: Polygon, outline: Polygon) -> tuple[Point, Point] | None:
    """A point on the room's facade (`END_GAP` from a wall's ends) and one `INSIDE` in."""
    lines = shapely.get_parts(room.boundary.intersection(outline.exterior))
    runs = [list(g.coords) for g in lines if isinstance(g, LineString)]
    segments = [(c[k], c[k + 1]) for c in runs for k in range(len(c) - 1)
                if math.dist(c[k], c[k + 1]) >= 2 * END_GAP + 2]
    if not segments:
        return None
    (xa, ya), (xb, yb) = rng.choice(segments)
    length = math.dist((xa, ya), (xb, yb))
    t = rng.randint(END_GAP, round(length) - END_GAP) / length
    door = Point(round(xa + t * (xb - xa)), round(ya + t * (yb - ya)))
    nx, ny = (0, 1) if ya == yb else (1, 0)
    for sign in (1, -1):
        inside = Point(door.x + sign * nx * INSIDE / UNIT, door.y + sign * ny * INSIDE / UNIT)
        if room.contains(inside):
            return door, inside
    return None


def _plan(rng: random.Random, n: int) -> _Plan:
    """Draw until a plan holds together (deterministic: one generator throughout)."""
    for _ in range(1000):
        outline = _outline(rng, n)
        pairs = 1 if n < 8 else rng.choice((1, 2))
        rooms = _clipped_rooms(rng, outline, n, pairs)
        if rooms is not None:
            rng.shuffle(rooms)
            return _Plan(outline, rooms, _types(rooms, outline))
    raise RuntimeError(f"no plan of {n} rooms after 1000 tries")


def draw(seed: int, rooms: int | None = None) -> tuple[Problem, Truth]:
    """The planted brief of `seed` and its plan; `rooms` from 5 to 14 when not given."""
    rng = random.Random(seed)
    n = rooms if rooms is not None else rng.randint(5, 14)
    for _ in range(1000):
        plan = _plan(rng, n)
        start = plan.types.index("living")  # the entrance opens into the living room
        doors = _doors(plan.rooms, start)
        entrance = _entrance(rng, plan.rooms[start], plan.outline)
        if doors is not None and entrance is not None:
            return _extract(plan, start, doors, entrance, f"planted-{n:02d}-{seed}", seed)
    raise RuntimeError(f"no connected plan of {n} rooms for seed {seed}")


def _ring(poly: Polygon) -> list[tuple[float, float]]:
    """The polygon's vertices in metres, counter-clockwise, without the closing one."""
    coords = list(orient(poly.simplify(0), 1.0).exterior.coords)[:-1]
    return [(_m(x), _m(y)) for x, y in coords]


def _sides(room: Polygon, outline: Polygon) -> list[str]:
    """The compass sides of the outline whose edges the room runs along."""
    touched = {e.facing for e in boundary_edges([(x, y) for x, y in outline.exterior.coords[:-1]])
               if room.boundary.intersection(LineString([e.start, e.end])).length > 0}
    return [s for s in COMPASS if s in touched]


def _room_brief(room_id: str, kind: str, poly: Polygon, outline: Polygon) -> dict[str, Any]:
    """One room's requirements, extracted from its bounding box."""
    x0, y0, x1, y1 = poly.bounds
    w, d = _m(x1 - x0), _m(y1 - y0)
    short, long = min(w, d), max(w, d)
    out: dict[str, Any] = {"id": room_id, "type": kind,
                           "min_size": [_floor2(0.8 * short)] * 2,
                           "max_size": [_ceil2(1.25 * long)] * 2, "target_size": [w, d]}
    if kind == "bedroom":
        out["aspect_ratio"] = [1.0, _ceil2(1.2 * long / short)]
    if kind in ("bedroom", "balcony") and (sides := _sides(poly, outline)):
        out["boundary"] = sides
    return out


def _extract(plan: _Plan, start: int, doors: list[tuple[int, int, float]],
             entrance: tuple[Point, Point], name: str, seed: int | None) -> tuple[Problem, Truth]:
    """The brief of a plan, as briefs are extracted from real plans, and the plan."""
    counts: dict[str, int] = {}
    ids = []
    for kind in plan.types:
        counts[kind] = counts.get(kind, 0) + 1
        ids.append(f"{kind}{counts[kind]}")
    rooms = [_room_brief(i, t, p, plan.outline)
             for i, t, p in zip(ids, plan.types, plan.rooms, strict=True)]
    door, inside = entrance
    rooms[start]["positions"] = [[_m(inside.x), _m(inside.y)]]
    brief = {"name": name, "boundary": [list(p) for p in _ring(plan.outline)],
             "entrance": [_m(door.x), _m(door.y)], "rooms": rooms,
             "adjacency": [{"a": ids[a], "b": ids[b], "min_contact": min(0.9, _m(wall))}
                           for a, b, wall in doors]}
    truth = Truth(name, seed, tuple(PlantedRoom(i, t, tuple(_ring(p)))
                                    for i, t, p in zip(ids, plan.types, plan.rooms, strict=True)))
    return Problem.model_validate(brief), truth


def load(path: Path) -> tuple[Problem, Truth]:
    """A brief and its plan from NAME.json and NAME.truth.json (either path given)."""
    stem = path.name.removesuffix(".json").removesuffix(".truth")
    brief, plan = path.with_name(f"{stem}.json"), path.with_name(f"{stem}.truth.json")
    problem = Problem.model_validate_json(brief.read_text(encoding="utf-8"))
    return problem, Truth.from_json(json.loads(plan.read_text(encoding="utf-8")))


def brief_json(problem: Problem) -> dict[str, Any]:
    """The brief as the files of bench/data hold it: the fields given, nothing defaulted."""
    return problem.model_dump(mode="json", exclude_unset=True)


def write(problem: Problem, truth: Truth, out: Path) -> list[Path]:
    """NAME.json and NAME.truth.json in `out`, formatted as the files of bench/data are."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / f"{truth.name}.json", out / f"{truth.name}.truth.json"]
    for path, data in zip(paths, (brief_json(problem), truth.to_json()), strict=True):
        path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    return paths


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m bench.planted", description=(
        "Draw planted briefs: NAME.json (the brief) and NAME.truth.json (its plan)."))
    p.add_argument("--seed", type=int, nargs="+", required=True, help="one brief per seed")
    p.add_argument("--rooms", type=int, default=None, help="room count (default: 5 to 14)")
    p.add_argument("--out", type=Path, required=True, help="output directory")
    args = p.parse_args(argv)
    for seed in args.seed:
        problem, truth = draw(seed, args.rooms)
        for path in write(problem, truth, args.out):
            print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
