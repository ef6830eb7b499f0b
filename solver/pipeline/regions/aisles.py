"""Aisles between regions (paper Sec. 5.3, large layouts): the walls regions share are
widened into corridors of the aisle width, joined into one network that reaches the
entrance, and what is left of each region is where its rooms go.

Pure geometry on shapely polygons; no SCIP. `regions/run.py` drives it.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import shapely
from shapely.geometry import LineString, MultiPolygon, Point, Polygon, box
from shapely.geometry.base import BaseGeometry

from floorplan.solver.geometry import GRID

#: Areas below this (m²) are slivers of floating-point, not floor.
SLIVER_AREA = 1e-4
#: A piece of a region narrower than this (metres) holds no room: it joins the aisle.
NARROWEST_PART = 1.0
#: Extra cost of a turn, in cells, for a connecting aisle: straight corridors read better.
TURN_COST = 2.0
#: Cells already mostly aisle cost this much (they widen nothing).
AISLE_CELL_COST = 0.05


@dataclass(frozen=True)
class AislePiece:
    """One aisle: a polygon (no holes) and the regions it runs along."""

    polygon: Polygon
    regions: tuple[str, ...]


@dataclass(frozen=True)
class AisleNetwork:
    """The aisles and, per region, the parts of it left for rooms (largest first)."""

    pieces: list[AislePiece]
    parts: dict[str, list[Polygon]]

    @property
    def union(self) -> BaseGeometry:
        return _clean(shapely.union_all([p.polygon for p in self.pieces]))


def aisle_network(
    free: BaseGeometry,
    outline: Polygon,
    regions: Mapping[str, BaseGeometry],
    width: float,
    *,
    entrance: tuple[float, float] | None = None,
    keep: Mapping[str, Sequence[tuple[float, float]]] | None = None,
) -> AisleNetwork:
    """Widen the walls `regions` share into aisles `width` wide, add the floor no region
    covers where it touches them, a vestibule at `entrance`, and straight connectors
    until the aisles form one network; `keep` lists per region the points its rooms must
    cover, which an aisle avoids by taking its whole width from the other side."""
    keep = keep or {}
    strips: list[tuple[BaseGeometry, tuple[str, ...]]] = []
    for a, b in itertools.combinations(sorted(regions), 2):
        for segment in _segments(regions[a].boundary.intersection(regions[b].boundary)):
            strip = _strip(segment, regions[a], regions[b], width, keep.get(a, ()),
                           keep.get(b, ()))
            if strip is not None:
                strips.append((strip, (a, b)))
    extra: list[BaseGeometry] = []
    if entrance is not None:
        extra.append(vestibule(free, outline, entrance, width))
    strips = _without_end_strips(strips, extra, free, outline, regions, width,
                                 facade=entrance is None)
    current = _clean(shapely.union_all([s for s, _ in strips] + extra).intersection(free))
    if current.is_empty:
        current = spine(free, outline, entrance, width)
        extra.append(current)
    # Floor the regions left uncovered becomes aisle where it opens onto one.
    gaps = _clean(free.difference(shapely.union_all(list(regions.values()))).difference(current))
    for gap in _polygons(gaps):
        if gap.area > SLIVER_AREA and gap.distance(current) <= 1e-6:
            extra.append(gap)
    current = _clean(shapely.union_all([current, *extra]).intersection(free))
    connectors = connect(free, current, width)
    extra += connectors
    current = _clean(shapely.union_all([current, *connectors]).intersection(free))
    parts: dict[str, list[Polygon]] = {}
    for region_id, shape in regions.items():
        left = [p for p in _polygons(_clean(shape.difference(current))) if p.area > SLIVER_AREA]
        usable = [p for p in left if _narrowest(p) >= NARROWEST_PART]
        extra += [p for p in left if _narrowest(p) < NARROWEST_PART]
        parts[region_id] = sorted(usable, key=lambda p: -p.area)
    pieces = _disjoint([s for s, _ in strips] + extra, free, regions)
    return AisleNetwork(pieces, parts)


def _without_end_strips(
    strips: Sequence[tuple[BaseGeometry, tuple[str, str]]], extra: Sequence[BaseGeometry],
    free: BaseGeometry, outline: Polygon, regions: Mapping[str, BaseGeometry], width: float,
    *, facade: bool,
) -> list[tuple[BaseGeometry, tuple[str, str]]]:
    """The strips less those along the short ends of both their regions (two bars end
    to end) that the network does without: it stays as connected as before, every
    region keeps at least two aisle widths of wall on it, and (`facade`: no entrance)
    it still meets the facade. Such a strip gives no room an aisle its row lacks, and
    takes floor the rooms asked for. Shortest first."""
    def short_end(strip: BaseGeometry, pair: tuple[str, str]) -> bool:
        x0, y0, x1, y1 = strip.bounds
        length = max(x1 - x0, y1 - y0)
        horizontal = x1 - x0 >= y1 - y0
        for r in pair:
            rx0, ry0, rx1, ry1 = regions[r].bounds
            along, across = (rx1 - rx0, ry1 - ry0) if horizontal else (ry1 - ry0, rx1 - rx0)
            if along > across + 1e-6 or length < along - width:
                return False
        return True

    def network(kept: Sequence[BaseGeometry]) -> BaseGeometry:
        return _clean(shapely.union_all([*kept, *extra]).intersection(free))

    def parts(shape: BaseGeometry) -> int:
        return len(_polygons(_clean(shape.buffer(1e-4, join_style="mitre"))))

    def touching(shape: BaseGeometry) -> bool:
        grown = shape.buffer(1e-4, join_style="mitre")
        return all(float(region.boundary.intersection(grown).length) >= 2 * width
                   for region in regions.values())

    kept = list(strips)
    whole = network([s for s, _ in kept])
    if whole.is_empty or not touching(whole):
        return kept
    count = parts(whole)
    ends = sorted((k for k, (s, pair) in enumerate(strips) if short_end(s, pair)),
                  key=lambda k: strips[k][0].area)
    dropped: set[int] = set()
    for k in ends:
        trial = [s for j, (s, _) in enumerate(strips) if j not in dropped | {k}]
        shape = network(trial)
        if shape.is_empty or parts(shape) > count or not touching(shape):
            continue
        if facade and shape.boundary.intersection(outline.exterior).length < width:
            continue
        dropped.add(k)
    return [strip for j, strip in enumerate(strips) if j not in dropped]


def vestibule(
    free: BaseGeometry, outline: Polygon, entrance: tuple[float, float], width: float
) -> BaseGeometry:
    """A `width` square of floor inside the front door, centred on the entrance."""
    where = Point(entrance)
    ring = outline.exterior
    along = ring.project(where)
    before, after = ring.interpolate(along - 1e-3), ring.interpolate(along + 1e-3)
    horizontal = abs(after.y - before.y) < abs(after.x - before.x)
    x, y = entrance
    half = width / 2
    for inward in (1, -1):
        square = (box(x - half, y, x + half, y + inward * width) if horizontal
                  else box(x, y - half, x + inward * width, y + half))
        square = shapely.normalize(square)
        if square.intersection(free).area > square.area / 2:
            return _clean(square.intersection(free))
    return _clean(where.buffer(half, cap_style="square").intersection(free))


def spine(free: BaseGeometry, outline: Polygon, entrance: tuple[float, float] | None,
          width: float) -> BaseGeometry:
    """One aisle when no two regions share a wall: from the entrance straight across
    the floor, else along the middle of the floor's longer side."""
    x0, y0, x1, y1 = free.bounds
    half = width / 2
    if entrance is not None:
        door = vestibule(free, outline, entrance, width)
        dx0, dy0, dx1, dy1 = door.bounds
        across = (box(dx0, y0, dx1, y1) if dx1 - dx0 >= width - 1e-6 and dy1 - dy0 <= width + 1e-6
                  and (abs(dy0 - y0) < 1e-6 or abs(dy1 - y1) < 1e-6)
                  else box(x0, dy0, x1, dy1))
        return _clean(across.intersection(free))
    if x1 - x0 >= y1 - y0:
        mid = (y0 + y1) / 2
        return _clean(box(x0, mid - half, x1, mid + half).intersection(free))
    mid = (x0 + x1) / 2
    return _clean(box(mid - half, y0, mid + half, y1).intersection(free))


def connect(free: BaseGeometry, aisles: BaseGeometry, width: float) -> list[BaseGeometry]:
    """Corridors `width` wide joining the parts of `aisles` into one: a shortest path
    of `width` cells over the free floor, turns penalised, from the largest part to
    each other part in turn."""
    parts = sorted(_polygons(aisles), key=lambda p: -p.area)
    if len(parts) <= 1:
        return []
    x0, y0, x1, y1 = free.bounds
    nx, ny = max(1, math.ceil((x1 - x0) / width)), max(1, math.ceil((y1 - y0) / width))
    cells: dict[tuple[int, int], Polygon] = {}
    shapely.prepare(free)
    for i in range(nx):
        for j in range(ny):
            cell = box(x0 + i * width, y0 + j * width, min(x1, x0 + (i + 1) * width),
                       min(y1, y0 + (j + 1) * width))
            if cell.difference(free).area <= SLIVER_AREA:
                cells[(i, j)] = cell
    joined = parts[0]
    connectors: list[BaseGeometry] = []
    for other in parts[1:]:
        if joined.distance(other) <= 1e-6 and joined.intersection(other).length > 1e-3:
            joined = shapely.union_all([joined, other])
            continue
        path = _cell_path(cells, joined, other)
        if path is None:
            continue
        corridor = shapely.union_all([cells[c] for c in path])
        connectors.append(corridor)
        joined = shapely.union_all([joined, corridor, other])
    return connectors


def _cell_path(cells: Mapping[tuple[int, int], Polygon], source: BaseGeometry,
               target: BaseGeometry) -> list[tuple[int, int]] | None:
    """Dijkstra over cells (state: cell and heading) from cells overlapping `source` to
    a cell overlapping `target`; cells already in `source` cost almost nothing."""
    def overlaps(cell: Polygon, shape: BaseGeometry) -> bool:
        return cell.intersection(shape).area > 1e-3

    starts = [c for c, cell in cells.items() if overlaps(cell, source)]
    goals = {c for c, cell in cells.items() if overlaps(cell, target)}
    if not starts or not goals:
        return None
    inside = {c for c in starts if cells[c].difference(source).area <= SLIVER_AREA}
    counter = itertools.count()
    queue: list[tuple[float, int, tuple[int, int], int, tuple[tuple[int, int], ...]]] = [
        (0.0, next(counter), c, -1, (c,)) for c in starts]
    best: dict[tuple[tuple[int, int], int], float] = {}
    while queue:
        cost, _, here, heading, path = heapq.heappop(queue)
        if here in goals:
            return list(path)
        if best.get((here, heading), math.inf) <= cost:
            continue
        best[(here, heading)] = cost
        for d, (di, dj) in enumerate(((1, 0), (-1, 0), (0, 1), (0, -1))):
            there = (here[0] + di, here[1] + dj)
            if there not in cells:
                continue
            step = AISLE_CELL_COST if there in inside else 1.0
            step += TURN_COST if heading not in (-1, d) else 0.0
            heapq.heappush(queue, (cost + step, next(counter), there, d, (*path, there)))
    return None


def _strip(segment: LineString, a: BaseGeometry, b: BaseGeometry, width: float,
           keep_a: Sequence[tuple[float, float]],
           keep_b: Sequence[tuple[float, float]]) -> Polygon | None:
    """The aisle along a wall `a` and `b` share: `width` wide, half on each side, or all
    on one side when a point the other side's rooms must cover would fall in it."""
    (sx, sy), (ex, ey) = segment.coords[0], segment.coords[-1]
    if segment.length <= 1e-6:
        return None
    horizontal = abs(ey - sy) < abs(ex - sx)
    lo, hi = (min(sx, ex), max(sx, ex)) if horizontal else (min(sy, ey), max(sy, ey))
    line = sy if horizontal else sx
    mid = (lo + hi) / 2
    probe = Point(mid, line + 1e-4) if horizontal else Point(line + 1e-4, mid)
    # Depth of the aisle on the + side (north or east) and on the - side.
    a_plus = a.distance(probe) < b.distance(probe)

    def band(minus: float, plus: float) -> Polygon:
        return (box(lo, line - minus, hi, line + plus) if horizontal
                else box(line - minus, lo, line + plus, hi))

    def hits(points: Sequence[tuple[float, float]], area: Polygon) -> bool:
        return any(area.buffer(1e-3).contains(Point(p)) for p in points)

    half = width / 2
    plus_keep, minus_keep = (keep_a, keep_b) if a_plus else (keep_b, keep_a)
    plus, minus = half, half
    if hits(plus_keep, band(0, half)) and not hits(minus_keep, band(width, 0)):
        plus, minus = 0.0, width
    elif hits(minus_keep, band(half, 0)) and not hits(plus_keep, band(0, width)):
        plus, minus = width, 0.0
    return band(minus, plus)


def _disjoint(shapes: Sequence[BaseGeometry], free: BaseGeometry,
              regions: Mapping[str, BaseGeometry]) -> list[AislePiece]:
    """The aisle shapes made disjoint, split into polygons without holes, each with the
    regions it runs along."""
    pieces: list[AislePiece] = []
    taken: BaseGeometry = Polygon()
    for shape in shapes:
        own = _clean(shape.intersection(free).difference(taken))
        taken = _clean(shapely.union_all([taken, own]))
        for polygon in _polygons(own):
            if polygon.area <= SLIVER_AREA:
                continue
            for simple in _without_holes(polygon):
                along = tuple(r for r, shape_r in regions.items()
                              if simple.boundary.intersection(shape_r.boundary).length > 0.1)
                pieces.append(AislePiece(shapely.orient_polygons(simple), along))
    return pieces


def aisle_pieces(shapes: Sequence[BaseGeometry], free: BaseGeometry,
                 regions: Mapping[str, BaseGeometry], *,
                 keep_regions: Sequence[tuple[str, ...]] = ()) -> list[AislePiece]:
    """`shapes` as disjoint aisle pieces; the first ones keep `keep_regions`."""
    pieces = _disjoint(shapes, free, regions)
    named = list(keep_regions)
    return [AislePiece(p.polygon, named[k] if k < len(named) else p.regions)
            for k, p in enumerate(pieces)]


def _without_holes(polygon: Polygon) -> list[Polygon]:
    """A polygon with holes cut into pieces without: by the vertical lines through each
    hole's left and right side."""
    if not polygon.interiors:
        return [polygon]
    xs = sorted({round(x, 9) for hole in polygon.interiors for x, _ in hole.coords})
    x0, y0, x1, y1 = polygon.bounds
    cuts = [x0, *[x for x in xs if x0 < x < x1], x1]
    out: list[Polygon] = []
    for left, right in itertools.pairwise(cuts):
        out += [p for p in _polygons(_clean(polygon.intersection(box(left, y0, right, y1))))
                if p.area > SLIVER_AREA]
    return [q for p in out for q in _without_holes(p)] if any(p.interiors for p in out) else out


def _segments(geometry: BaseGeometry) -> list[LineString]:
    """The straight pieces of a shared boundary (points where regions only meet at a
    corner are dropped)."""
    lines = [g for g in getattr(geometry, "geoms", [geometry])
             if isinstance(g, LineString) and g.length > 1e-6]
    if not lines:
        return []
    merged = shapely.line_merge(shapely.union_all(lines))
    out = []
    for line in getattr(merged, "geoms", [merged]):
        coords = list(line.coords)
        for p, q in itertools.pairwise(coords):
            if math.dist(p, q) > 1e-6:
                out.append(LineString([p, q]))
    return out


def _narrowest(polygon: Polygon) -> float:
    """The smaller side of the polygon's bounding box: a strip thinner than this holds
    no room."""
    x0, y0, x1, y1 = polygon.bounds
    width = min(x1 - x0, y1 - y0)
    # An L of thin arms has a large box: look at the thickest rectangle it holds too.
    eroded = polygon.buffer(-NARROWEST_PART / 2 + 1e-6, join_style="mitre")
    return width if not eroded.is_empty else 0.0


def _polygons(geometry: BaseGeometry) -> list[Polygon]:
    if geometry.is_empty:
        return []
    if isinstance(geometry, Polygon):
        return [geometry]
    if isinstance(geometry, MultiPolygon):
        return list(geometry.geoms)
    return [g for g in getattr(geometry, "geoms", []) if isinstance(g, Polygon)]


def _clean(geometry: BaseGeometry) -> BaseGeometry:
    """Snapped to the grid and stripped of lines and points left by set operations."""
    snapped = shapely.set_precision(geometry, GRID)
    polygons = [p for p in _polygons(snapped) if p.area > 0]
    if not polygons:
        return Polygon()
    merged = shapely.union_all(polygons)
    return shapely.simplify(merged, 0)


def clean_shape(geometry: BaseGeometry) -> BaseGeometry:
    """`geometry` snapped to the grid, without the lines and points set operations leave."""
    return _clean(geometry)
