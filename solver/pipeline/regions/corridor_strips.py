"""A block between corridors cut into strips one cell deep along its corridors
(`corridors.plan_corridors` makes the blocks): each cell's piece goes with the side whose
corridor it runs along, and a cell in a floor's corner, on no corridor of its own,
becomes a one-room strip whose room reaches past the corridor's end for its door."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.base import BaseGeometry

from floorplan.solver.network import Mesh
from floorplan.solver.pipeline.regions.aisles import (
    NARROWEST_PART,
    SLIVER_AREA,
    clean_shape,
)
from floorplan.solver.pipeline.regions.parts import polygon_pieces

#: Metres of corridor along a side that make a cell's piece a candidate for that side's
#: strip (a corner cell on two corridors goes with the strip its neighbours form).
CORNER_CONTACT = 1.0
#: Metres a corner room's wall runs along the corridor beyond a door and its clearances.
CORNER_MARGIN = 0.1


def _strips(
    block: Polygon, mesh: Mesh, corridors: BaseGeometry, narrowest: float,
    corner: CornerRoom | None = None, singles: list[Polygon] | None = None,
) -> tuple[list[Polygon], list[Polygon]]:
    """A block cut into strips one cell deep along its corridors, so one row of rooms
    laid out in a strip opens onto its corridor: the block's pieces in each grid cell,
    each keyed by the side it shares most with a corridor (a row of cells along a
    corridor running along x, or a column along one running along y), the pieces of a
    key joined. A corner piece, on two corridors, takes the key its neighbours share (a
    wall column of office-154 came out as three one-cell blocks of two rooms each, one
    without a door). A piece touching no corridor joins the neighbour it shares most
    wall with. A cell's slivers (a lip between an obstacle and a grid line, narrower
    than `narrowest` metres) are corridor floor where they touch a corridor (returned
    second), else left out (slicing made a 0.25 m lip above mall-140's stairs a room of
    its own). Cutting a whole block one way cut an L-shaped block (a column along a wall
    joined to a row) across its column's rooms. With `corner` and `singles`, a piece in
    a floor's corner that touches no corridor takes the end of a strip beside it past
    the corridor's end, as a strip of one room (`_corner_strip`), appended to `singles`
    as well."""
    grown = corridors.buffer(1e-4, join_style="mitre")
    x0, y0, x1, y1 = block.bounds
    xs = [x for x in mesh.xs if x0 + 1e-6 < x < x1 - 1e-6]
    ys = [y for y in mesh.ys if y0 + 1e-6 < y < y1 - 1e-6]
    pieces: list[tuple[list[tuple[str, int]], Polygon]] = []
    loose: list[Polygon] = []
    floor: list[Polygon] = []
    for i, (a, b) in enumerate(itertools.pairwise([x0, *xs, x1])):
        for j, (c, d) in enumerate(itertools.pairwise([y0, *ys, y1])):
            cell = clean_shape(block.intersection(shapely.box(a, c, b, d)))
            # Slivers of the cell (a lip along an obstacle) are corridor floor beside a
            # corridor; the rest is kept.
            opened = cell.buffer(-narrowest / 2, join_style="mitre").buffer(
                narrowest / 2, join_style="mitre").intersection(cell)
            for sliver in polygon_pieces(clean_shape(cell.difference(opened))):
                if sliver.area > SLIVER_AREA and sliver.intersects(grown):
                    floor.append(sliver)
            for piece in (q for whole in polygon_pieces(clean_shape(opened))
                          for q in _at_corridor_end(whole, grown, corridors, corner)):
                if piece.area <= SLIVER_AREA:
                    continue
                along_x, along_y = _contact(piece, grown)
                if max(along_x, along_y) <= 1e-3:
                    loose.append(piece)
                    continue
                keys = [(along_x, ("row", j)), (along_y, ("column", i))]
                keys.sort(key=lambda k: -k[0])
                sides = [k for c, k in keys if c >= CORNER_CONTACT] or [keys[0][1]]
                pieces.append((sides, piece))
    # A piece on two corridors (a corner) joins the strip of the key others share.
    members: dict[tuple[str, int], int] = {}
    for keys, _ in pieces:
        if len(keys) == 1:
            members[keys[0]] = members.get(keys[0], 0) + 1
    groups: dict[tuple[str, int], list[Polygon]] = {}
    for keys, piece in pieces:
        key = max(keys, key=lambda k: (members.get(k, 0), -keys.index(k)))
        groups.setdefault(key, []).append(piece)
    out = [
        p
        for members in groups.values()
        for p in polygon_pieces(clean_shape(shapely.union_all(members)))
        if p.area > SLIVER_AREA
    ]
    if not out:
        return [block], []
    thin = [p for p in out if p.buffer(-NARROWEST_PART / 2 + 1e-6, join_style="mitre").is_empty]
    out = [p for p in out if not any(p is t for t in thin)] or out
    for piece in [*loose, *(t for t in thin if not any(t is p for p in out))]:
        taken = None if corner is None else _corner_strip(piece, out, grown, corner)
        if taken is not None and singles is not None:
            k, rest, strip = taken
            out[k] = rest
            out.append(strip)
            singles.append(strip)
            continue
        k = max(range(len(out)), key=lambda k: out[k].intersection(piece.buffer(1e-4)).area)
        joined = polygon_pieces(clean_shape(shapely.union_all([out[k], piece])))
        out[k] = max(joined, key=lambda p: p.area)
    return out, floor


@dataclass(frozen=True)
class CornerRoom:
    """What a room in a floor's corner needs (`_corner_strip`): `reach` metres of wall
    on the corridor (a door and its clearances), and the room's planned size."""

    reach: float
    size: tuple[float, float]
    #: The free floor's convex corners (`_corner_points`).
    corners: tuple[tuple[float, float], ...] = ()


def _corner_strip(
    piece: Polygon, strips: list[Polygon], grown: BaseGeometry, corner: CornerRoom
) -> tuple[int, Polygon, Polygon] | None:
    """For a piece in a floor's corner with no corridor of its own (`_floor_corner`):
    of the strips beside it whose corridor ends level with it, the one whose end up to
    `corner.reach` past the corridor's end makes with the piece a room's place nearest
    `corner.size`; that strip's index, the strip less its end, and the piece with that
    end. None when no strip beside it serves.
    Joined to a whole strip, the corner's room was sliced off the corridor (office-154
    and mall-140 lost a room's door in each corner; bench/NOTES.md, "Corridors")."""
    best = None
    reach = corner.reach
    for k, strip in enumerate(strips):
        shared = strip.intersection(piece.buffer(1e-4, join_style="mitre")).area
        if shared <= 1e-6:
            continue
        contact = strip.boundary.intersection(grown)
        if contact.is_empty:
            continue
        c0, d0, c1, d1 = contact.bounds
        x0, y0, x1, y1 = strip.bounds
        px0, py0, px1, py1 = piece.bounds
        if c1 - c0 >= d1 - d0:  # a row on a corridor along x
            if px1 <= c0 + 1e-6:
                cut = shapely.box(x0 - 1, y0 - 1, c0 + reach, y1 + 1)
            elif px0 >= c1 - 1e-6:
                cut = shapely.box(c1 - reach, y0 - 1, x1 + 1, y1 + 1)
            else:
                continue
        elif py1 <= d0 + 1e-6:
            cut = shapely.box(x0 - 1, y0 - 1, x1 + 1, d0 + reach)
        elif py0 >= d1 - 1e-6:
            cut = shapely.box(x0 - 1, d1 - reach, x1 + 1, y1 + 1)
        else:
            continue
        end = clean_shape(strip.intersection(cut))
        rest = polygon_pieces(clean_shape(strip.difference(cut)))
        joined = polygon_pieces(clean_shape(shapely.union_all([end, piece])))
        if len(rest) != 1 or len(joined) != 1 or rest[0].area < 2 * end.area:
            continue
        jx0, jy0, jx1, jy1 = joined[0].bounds
        misfit = (jx1 - jx0 - corner.size[0]) ** 2 + (jy1 - jy0 - corner.size[1]) ** 2
        if best is None or misfit < best[0]:
            best = (misfit, k, rest[0], joined[0])
    return None if best is None else best[1:]


def _at_corridor_end(piece: Polygon, grown: BaseGeometry, corridors: BaseGeometry,
                     corner: CornerRoom | None) -> list[Polygon]:
    """`piece` cut along the corridors' sides that end inside it, when it holds a corner
    of the floor (`corner.corners`) and touches the corridors for less than
    `CORNER_CONTACT` either way: a cell in a floor's corner (no corridor
    of its own, `_floor_corner`) wraps round a corridor's end, and sliced whole it gave a
    0.9 m room beside that end; cut, its part level with the corridor joins the column
    along the cross corridor, the rest the row (bench/NOTES.md, "Corridors")."""
    if corner is None or not any(
        piece.distance(shapely.Point(c)) <= 1e-6 for c in corner.corners
    ):
        return [piece]
    along_x, along_y = _contact(piece, grown)
    if max(along_x, along_y) >= CORNER_CONTACT:
        return [piece]
    x0, y0, x1, y1 = piece.bounds
    near = corridors.intersection(shapely.box(x0 - 1e-3, y0 - 1e-3, x1 + 1e-3, y1 + 1e-3))
    points = shapely.get_coordinates(near)
    xs = sorted({round(x, 9) for x, _ in points if x0 + 1e-6 < x < x1 - 1e-6})
    ys = sorted({round(y, 9) for _, y in points if y0 + 1e-6 < y < y1 - 1e-6})
    if not xs and not ys:
        return [piece]
    out = []
    for a, b in itertools.pairwise([x0, *xs, x1]):
        for c, d in itertools.pairwise([y0, *ys, y1]):
            out += polygon_pieces(clean_shape(piece.intersection(shapely.box(a, c, b, d))))
    return out


def _contact(piece: Polygon, grown: BaseGeometry) -> tuple[float, float]:
    """Length of `piece`'s outline along the corridors on its sides running along x and
    along y."""
    along_x = along_y = 0.0
    coords = list(piece.exterior.coords)
    for p, q in itertools.pairwise(coords):
        shared = LineString([p, q]).intersection(grown).length
        if abs(q[1] - p[1]) <= 1e-9:
            along_x += shared
        elif abs(q[0] - p[0]) <= 1e-9:
            along_y += shared
    return along_x, along_y
