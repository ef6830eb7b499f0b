"""The reshaping's steps and what they are made of: strips of floor across the walls two
rooms share (`strip_cuts`, and `strip_extent` to refuse one before it is built), a room
set into a corner of another (`nest`), the pairs of neighbours, and the uncovered floor
as pseudo-rooms (`gaps`)."""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator, Mapping, Sequence

import shapely
from shapely.geometry import Point, Polygon, box
from shapely.geometry.base import BaseGeometry

from floorplan.solver.geometry import GRID, Domain, shared_wall_length, straight_stretches
from floorplan.solver.heuristics.reshape.needs import MIN_ARM, TOL, Rect, RoomNeeds

#: Steps of a wall shorter than this (metres) are left as they are; a strip as deep as
#: a longer one may straighten it.
JOG = 1e-4
#: A strip thinner than this (metres) is not worth a corner.
MIN_STRIP = 0.05
#: Pseudo-rooms of uncovered floor are named so.
GAP = "~gap"


def strip_extent(pieces: Sequence[Rect], cut: Rect
                  ) -> tuple[float, Rect, Rect | None] | None:
    """What cutting the box `cut` out of a room made of the disjoint rectangles
    `pieces` takes: the strip's area and bounds, and the bounds of what the room keeps
    (None: nothing); None when the strip is no thicker than a jog."""
    cx0, cy0, cx1, cy1 = cut
    area = 0.0
    strip: list[Rect] = []
    rest: list[Rect] = []
    for x0, y0, x1, y1 in pieces:
        ix0, iy0, ix1, iy1 = max(x0, cx0), max(y0, cy0), min(x1, cx1), min(y1, cy1)
        if ix1 - ix0 <= 0 or iy1 - iy0 <= 0:
            rest.append((x0, y0, x1, y1))
            continue
        area += (ix1 - ix0) * (iy1 - iy0)
        strip.append((ix0, iy0, ix1, iy1))
        # What the piece keeps spans its whole width unless the cut spans its depth,
        # and then only the side(s) the cut leaves; the same across.
        across_x = cy0 <= y0 and cy1 >= y1
        across_y = cx0 <= x0 and cx1 >= x1
        if across_x and across_y:
            continue  # the cut takes the whole piece
        kx0, kx1 = x0, x1
        if across_x:
            kx0 = ix1 if cx0 <= x0 else x0
            kx1 = ix0 if cx1 >= x1 else x1
        ky0, ky1 = y0, y1
        if across_y:
            ky0 = iy1 if cy0 <= y0 else y0
            ky1 = iy0 if cy1 >= y1 else y1
        rest.append((kx0, ky0, kx1, ky1))
    if area <= JOG * JOG:
        return None
    kept = hull(*rest) if rest else None
    return area, hull(*strip), kept


def hull(*boxes: Rect) -> Rect:
    """The bounding box of boxes (x0, y0, x1, y1)."""
    return (min(b[0] for b in boxes), min(b[1] for b in boxes),
            max(b[2] for b in boxes), max(b[3] for b in boxes))


def strip_cuts(a: Polygon, b: Polygon, needs_a: RoomNeeds | None,
                needs_b: RoomNeeds | None) -> Iterator[tuple[float, float, float, float]]:
    """Boxes (x0, y0, x1, y1) cutting strips of `a` along the walls it shares with `b`:
    across each straight stretch of the shared wall, or part of it, as deep as one of
    `a`'s own corners, or as makes the width (or depth) of `a` or `b` its target's. The
    strip is `a` within the box; only the one drawn is cut (most are never drawn)."""
    shared = a.boundary.intersection(b.boundary)
    for x0, y0, x1, y1 in _segments(shared):
        vertical = abs(x0 - x1) <= TOL
        c = x0 if vertical else y0
        lo, hi = (min(y0, y1), max(y0, y1)) if vertical else (min(x0, x1), max(x0, x1))
        if hi - lo <= MIN_STRIP:
            continue
        mid = (lo + hi) / 2
        probe = Point(c - 1e-3, mid) if vertical else Point(mid, c - 1e-3)
        sign = -1.0 if a.contains(probe) else 1.0  # which way a lies from the wall
        axis = 0 if vertical else 1
        a_lo, a_hi = _extent(a, axis)
        b_lo, b_hi = _extent(b, axis)
        depths = {abs(c - v) for v in _coords(a, axis)}
        ta, tb = _target(needs_a, axis), _target(needs_b, axis)
        if ta is not None:
            depths.add((a_hi - a_lo) - ta)  # a shrinks to its target across the wall
        if tb is not None:
            depths.add(tb - (b_hi - b_lo))  # b grows to its target across the wall
        depths = {t for t in depths if JOG <= t <= (a_hi - a_lo) + TOL}
        # Along the wall: the corners of either room, and where what a keeps (or b
        # takes) is as long as a target asks.
        along = [*_coords(a, 1 - axis), *_coords(b, 1 - axis)]
        for t in (_target(needs_a, 1 - axis), _target(needs_b, 1 - axis)):
            if t is not None:
                along += [lo + t, hi - t]
        cuts = {lo, hi} | {v for v in along if lo + MIN_STRIP < v < hi - MIN_STRIP}
        ends = sorted(cuts)
        spans = [(s, e) for i, s in enumerate(ends) for e in ends[i + 1:]]
        for t in sorted(depths):
            for s, e in spans:
                near, far = c, c + sign * t
                if vertical:
                    yield min(near, far), s, max(near, far), e
                else:
                    yield s, min(near, far), e, max(near, far)


def _segments(shared: BaseGeometry) -> Iterator[tuple[float, float, float, float]]:
    """The axis-aligned straight stretches of a shared wall, as (x0, y0, x1, y1)."""
    for stretch in straight_stretches(shared):
        (x0, y0), (x1, y1) = stretch.coords[0], stretch.coords[-1]
        if abs(x0 - x1) <= TOL or abs(y0 - y1) <= TOL:
            yield x0, y0, x1, y1


def _extent(shape: Polygon, axis: int) -> tuple[float, float]:
    x0, y0, x1, y1 = shape.bounds
    return (x0, x1) if axis == 0 else (y0, y1)


def _coords(shape: Polygon, axis: int) -> set[float]:
    return {p[axis] for p in shape.exterior.coords}


def _target(needs: RoomNeeds | None, axis: int) -> float | None:
    target = None if needs is None else needs.room.target_size
    return None if target is None else target[axis]


def nest(state: Mapping[str, Polygon], needs: Mapping[str, RoomNeeds],
          pairs: Sequence[tuple[str, str]], rng: random.Random,
          rectangles_in: Callable[[str], list[Rect]],
          within_allowed: Callable[[Mapping[str, tuple[Rect | None, float]]], bool],
          ) -> dict[str, Polygon] | None:
    """A room moves into a corner of another, at its target size, and a neighbour takes
    the floor it leaves: a bathroom set into the corner of a living room that thereby
    becomes an L, where strips alone would have to pass through worse layouts. The
    host may be that neighbour itself. None when the drawn move does not fit, or when
    `within_allowed` refuses the rooms' bounds and areas before their shapes are built
    (`rectangles_in`: a room's floor as rectangles)."""
    a, heir = rng.choice(pairs)
    if a.startswith(GAP) or heir.startswith(GAP):
        return None
    target = needs[a].room.target_size
    if target is None:
        return None
    hosts = [r for r in needs if r != a and state[r].area > target[0] * target[1]]
    if not hosts:
        return None
    host_id = rng.choice(hosts)
    inherited: BaseGeometry | None = None
    if host_id == heir:
        inherited = clean(state[heir].union(state[a]))
        if inherited is None:
            return None
    host = inherited if inherited is not None else state[host_id]
    host_pieces = rectangles_in(host_id) + (rectangles_in(a) if host_id == heir else [])
    width, depth = target if rng.random() < 0.5 else target[::-1]
    x0, y0, x1, y1 = host.bounds
    # Where the host would keep a sliver thinner than an arm, the room takes it all.
    if x1 - x0 - width < MIN_ARM:
        width = x1 - x0
    if y1 - y0 - depth < MIN_ARM:
        depth = y1 - y0
    corners = list(dict.fromkeys(host.exterior.coords))
    vx, vy = rng.choice(corners)
    for sx, sy in rng.sample([(1, 1), (1, -1), (-1, 1), (-1, -1)], 4):
        corner = (min(vx, vx + sx * width), min(vy, vy + sy * depth),
                  max(vx, vx + sx * width), max(vy, vy + sy * depth))
        taken = strip_extent(host_pieces, corner)
        if taken is not None and taken[0] >= width * depth - JOG * JOG:
            break  # the corner lies within the host
    else:
        return None
    _, _, kept = taken
    changes: dict[str, tuple[Rect | None, float]] = {
        a: (corner, width * depth), host_id: (kept, host.area - width * depth)}
    if host_id != heir:
        changes[heir] = (hull(state[heir].bounds, state[a].bounds),
                         state[heir].area + state[a].area)
    if kept is None or not within_allowed(changes):
        return None
    rest = clean(host.difference(box(*corner)))
    if rest is None:
        return None
    moved = {a: shapely.orient_polygons(box(*corner)), host_id: rest}
    if host_id != heir:
        inherited = clean(state[heir].union(state[a]))
        if inherited is None:
            return None
        moved[heir] = inherited
    return moved


def neighbour_pairs(state: Mapping[str, Polygon], changed: set[str] | None = None,
                     known: Sequence[tuple[str, str]] = ()
                     ) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """Ordered pairs of rooms sharing a wall (a gives, b takes), sorted, and those of
    them in which a gap gives. With `changed`, the `known` pairs of the other rooms
    stand and only the changed rooms' walls are measured again."""
    ids = sorted(state)
    tree = shapely.STRtree([state[r] for r in ids])
    asked = ids if changed is None else [r for r in ids if r in changed]
    found = set() if changed is None else {
        (a, b) for a, b in known if a not in changed and b not in changed}
    for k, j in zip(*tree.query([state[r] for r in asked], "touches"), strict=True):
        a, b = asked[k], ids[j]
        if a != b and shared_wall_length(state[a], state[b]) > MIN_STRIP:
            found |= {(a, b), (b, a)}
    pairs = sorted(found)
    return pairs, [ab for ab in pairs if ab[0].startswith(GAP)]


def gaps(domain: Domain, state: Mapping[str, Polygon]) -> dict[str, Polygon]:
    """The uncovered parts of the floor as pseudo-rooms (`GAP` and a number)."""
    rest = shapely.set_precision(
        domain.free.difference(shapely.union_all(list(state.values()))), GRID)
    parts = [g for g in getattr(rest, "geoms", [rest])
             if isinstance(g, Polygon) and g.area > MIN_STRIP * MIN_STRIP]
    return {f"{GAP}{k}": g for k, g in enumerate(parts)}


def covered(domain: Domain, state: Mapping[str, Polygon]) -> float:
    return domain.area - sum(p.area for r, p in state.items() if r.startswith(GAP))


def clean(shape: BaseGeometry, gap: bool = False) -> BaseGeometry | None:
    """A step's result as one polygon without holes on the grid, or None; a gap may be
    anything (an emptied gap is gone)."""
    shape = shapely.set_precision(shape, GRID)
    if gap:
        return shape
    if (not isinstance(shape, Polygon) or shape.is_empty or shape.interiors
            or not shape.is_valid):
        return None
    return shapely.orient_polygons(shape.simplify(0))
