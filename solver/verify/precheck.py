"""Cheap impossibilities, found before any solving: each finding is a sentence a user
can act on. An empty list proves nothing; a non-empty one proves infeasibility."""

from __future__ import annotations

from functools import lru_cache

from shapely import affinity
from shapely.geometry.base import BaseGeometry

from floorplan.models import Problem, Room
from floorplan.solver.geometry import EPS, Domain, edges_named
from floorplan.solver.soft import hard_part


def find_impossibilities(
    problem: Problem, domain: Domain, *, ignore_soft: bool = True
) -> list[str]:
    """Every cheap reason why no layout can exist; soft constraints are not looked at
    unless `ignore_soft` is false (then: why no layout meets all of them)."""
    if ignore_soft:
        problem = hard_part(problem)
    findings = list(_total_area(problem, domain))
    for room in problem.rooms:
        findings += _room_fits(room, domain)
        findings += _ratio_within_sizes(room)
        findings += _positions_within_reach(room)
        findings += _boundary_reachable(problem, room, domain)
    findings += _adjacency_sane(problem)
    return findings


def _total_area(problem: Problem, domain: Domain) -> list[str]:
    need = sum(r.min_size[0] * r.min_size[1] for r in problem.rooms if r.min_size)
    # A room wrapped around an obstacle counts it within its minimum size.
    if need > domain.spannable.area + EPS:
        return [f"the rooms' minimum sizes need {need:.2f} m² but the free area is "
                f"{domain.area:.2f} m²"]
    return []


def _room_fits(room: Room, domain: Domain) -> list[str]:
    """A w x d rectangle fits in the free area iff, with x scaled by 1/w and y by 1/d,
    the area eroded by half a unit is not empty. The obstacles a room may wrap around
    count as free here: a room enclosing one is still a rectangle of its size. A room
    that may be an L or a T (`max_rects` unset or above 1) is sized by its bounding box,
    which may reach over the outline's notches: only the outline's own box bounds it."""
    if not room.min_size or min(room.min_size) <= EPS:
        return []
    w, d = room.min_size
    if room.max_rects != 1:
        box = domain.bbox
        if w > box.width + EPS or d > box.depth + EPS:
            return [f"room '{room.id}' needs at least {w:g} x {d:g} m, more than the "
                    f"outline's {box.width:g} x {box.depth:g} m bounding box"]
        return []
    if not _fits_somewhere(domain.spannable, w, d):
        return [f"room '{room.id}' needs at least {w:g} x {d:g} m, which fits nowhere in the "
                "free area"]
    return []


# The conflict search (solver/verify/conflicts.py) asks again and again about the same rooms.
@lru_cache(maxsize=4096)
def _fits_somewhere(free: BaseGeometry, w: float, d: float) -> bool:
    scaled = affinity.scale(free, xfact=1 / w, yfact=1 / d, origin=(0, 0))
    return not scaled.buffer(-0.5 + 1e-9, join_style="mitre").is_empty


def _ratio_within_sizes(room: Room) -> list[str]:
    if room.aspect_ratio is None:
        return []
    lo, hi = room.aspect_ratio
    wl, dl = room.min_size or (0.0, 0.0)
    wh, dh = room.max_size or (float("inf"), float("inf"))
    wide = lo * dl <= wh + EPS and wl <= hi * dh + EPS
    tall = lo * wl <= dh + EPS and dl <= hi * wh + EPS
    if not (wide or tall):
        return [f"room '{room.id}': no size within its bounds has an aspect ratio in "
                f"[{lo:g}, {hi:g}]"]
    return []


def _positions_within_reach(room: Room) -> list[str]:
    if len(room.positions) < 2 or room.max_size is None:
        return []
    (x1, y1), (x2, y2) = room.positions
    if abs(x1 - x2) > room.max_size[0] + EPS or abs(y1 - y2) > room.max_size[1] + EPS:
        return [f"room '{room.id}' cannot cover both its positions within its maximum size"]
    return []


def _boundary_reachable(problem: Problem, room: Room, domain: Domain) -> list[str]:
    if not room.boundary:
        return []
    edges = edges_named(problem, domain.edges, room.boundary)
    wl, dl = room.min_size or (0.0, 0.0)
    if not any(e.length + EPS >= (wl if e.horizontal else dl) for e in edges):
        names = ", ".join(str(b) for b in room.boundary)
        return [f"room '{room.id}' must lie along edge(s) {names}, but none is as long as "
                "the room's minimum side"]
    return []


def _adjacency_sane(problem: Problem) -> list[str]:
    findings = []
    regions = {region.id for region in problem.regions or []}
    for k, adj in enumerate(problem.adjacency):
        if adj.a in adj.partners:
            findings.append(f"adjacency {k} asks room '{adj.a}' to touch itself")
            continue
        if any(name in regions for name in (adj.a, *adj.partners)):
            continue  # two regions face each other across an aisle: no room sizes to compare
        reach_a = _longest_side(problem.room(adj.a))
        reach = max(min(reach_a, _longest_side(problem.room(p))) for p in adj.partners)
        if adj.min_contact > reach + EPS:
            findings.append(f"adjacency {k}: a contact of {adj.min_contact:g} m is longer "
                            f"than room '{adj.a}' or its partner can be")
    return findings


def _longest_side(room: Room) -> float:
    return max(room.max_size) if room.max_size else float("inf")
