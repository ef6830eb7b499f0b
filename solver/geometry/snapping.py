"""Snapping rooms' coordinates: near values made one so that shared walls are exactly
shared (`snap_rooms`), and runs of near walls moved onto one line (`wall_moves`,
`walls_moved`)."""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Mapping, Sequence

from floorplan.solver.geometry.boxes import EPS, Box


def snap_map(fixed: Iterable[float], loose: Iterable[float], tol: float) -> dict[float, float]:
    """Map each loose coordinate to the nearest fixed (domain) one within `tol`, else to the
    first of its run of loose coordinates spanning at most `tol`.

    >>> snap_map([5.0], [4.99991, 5.00008, 7.0, 7.00001, 7.00011], 1e-4)
    {4.99991: 5.0, 5.00008: 5.0, 7.0: 7.0, 7.00001: 7.0, 7.00011: 7.00011}
    """
    walls = sorted(set(fixed))
    mapping: dict[float, float] = {}
    anchor: float | None = None
    for value in sorted(set(loose)):
        k = bisect.bisect_left(walls, value)
        wall = min(walls[max(k - 1, 0):k + 1], key=lambda w: abs(w - value), default=None)
        if wall is not None and abs(wall - value) <= tol:
            mapping[value] = wall
            continue
        if anchor is None or value - anchor > tol:
            anchor = value
        mapping[value] = anchor
    return mapping


def snap_rooms(
    rooms: Mapping[str, Sequence[Box]], xs: Iterable[float], ys: Iterable[float], tol: float
) -> dict[str, list[Box]]:
    """Rooms with every coordinate within `tol` of a domain line (`xs`, `ys`) or of
    another room's coordinate moved onto one value, so shared walls are exactly shared.

    >>> snap_rooms({"a": [Box(0, 0, 2.0000001, 1)], "b": [Box(2, 0, 3, 1)]}, [0, 3], [0, 1], 1e-4)
    {'a': [Box(x0=0, y0=0, x1=2, y1=1)], 'b': [Box(x0=2, y0=0, x1=3, y1=1)]}
    """
    boxes = [b for rects in rooms.values() for b in rects]
    sx = snap_map(xs, [v for b in boxes for v in (b.x0, b.x1)], tol)
    sy = snap_map(ys, [v for b in boxes for v in (b.y0, b.y1)], tol)
    return {
        room_id: [Box(sx[b.x0], sy[b.y0], sx[b.x1], sy[b.y1]) for b in rects]
        for room_id, rects in rooms.items()
    }


def wall_runs(fixed: Iterable[float], walls: Iterable[tuple[float, float]], tol: float
              ) -> dict[float, float]:
    """Map each wall coordinate of `walls` ((coordinate, length) pairs) to one value per
    run of coordinates spanning at most `tol`: the fixed line within `tol` of the whole
    run when there is one, else the run's coordinate with the most wall on it (the wall
    the others line up with). A run near two fixed lines is left as it is.

    >>> wall_runs([0.0, 6.8], [(6.77, 2.0), (6.83, 3.8), (4.9, 1.0), (4.95, 4.0)], 0.1)
    {4.9: 4.95, 4.95: 4.95, 6.77: 6.8, 6.83: 6.8}
    """
    lines = sorted(set(fixed))
    length: dict[float, float] = {}
    for value, extent in walls:
        length[value] = length.get(value, 0.0) + extent
    runs: list[list[float]] = []
    for value in sorted(length):
        if runs and value - runs[-1][0] <= tol:
            runs[-1].append(value)
        else:
            runs.append([value])
    mapping: dict[float, float] = {}
    for run in runs:
        k = bisect.bisect_left(lines, run[-1] - tol)
        near = [w for w in lines[k:] if w <= run[0] + tol]
        if len(near) > 1:  # two walls of the outline this close: each keeps its own
            mapping.update({v: v for v in run})
            continue
        target = near[0] if near else max(run, key=lambda v: (length[v], -v))
        mapping.update(dict.fromkeys(run, target))
    return mapping


def wall_moves(
    rooms: Mapping[str, Sequence[Box]], xs: Iterable[float], ys: Iterable[float], tol: float
) -> list[tuple[int, dict[float, float]]]:
    """The runs of wall coordinates at most `tol` apart that `wall_runs` moves onto one
    line (the outline's `xs` and `ys` stay), each as (axis: 0 for x, 1 for y, the map of
    its coordinates), to be applied together or one at a time (`walls_moved`). All of
    them together keep the coordinates' order, so rooms that did not overlap still do
    not, and rooms that covered the floor still do."""
    boxes = [b for rects in rooms.values() for b in rects]
    moves: list[tuple[int, dict[float, float]]] = []
    for axis, fixed, walls in (
            (0, xs, [(v, b.depth) for b in boxes for v in (b.x0, b.x1)]),
            (1, ys, [(v, b.width) for b in boxes for v in (b.y0, b.y1)])):
        runs: dict[float, dict[float, float]] = {}
        for value, target in wall_runs(fixed, walls, tol).items():
            runs.setdefault(target, {})[value] = target
        moves += [(axis, run) for run in runs.values()
                  if any(value != target for value, target in run.items())]
    return moves


def walls_moved(rooms: Mapping[str, Sequence[Box]],
                moves: Iterable[tuple[int, dict[float, float]]]) -> dict[str, list[Box]]:
    """`rooms` with the wall coordinates of `moves` (`wall_moves`) moved, rectangles left
    without area dropped."""
    sx: dict[float, float] = {}
    sy: dict[float, float] = {}
    for axis, run in moves:
        (sx if axis == 0 else sy).update(run)
    moved = {room_id: [Box(sx.get(b.x0, b.x0), sy.get(b.y0, b.y0),
                           sx.get(b.x1, b.x1), sy.get(b.y1, b.y1)) for b in rects]
             for room_id, rects in rooms.items()}
    return {room_id: [b for b in rects if b.width > EPS and b.depth > EPS]
            for room_id, rects in moved.items()}
