"""Rooms around planned corridors (`corridors.py`): each room asked to touch a corridor
(C_boundary, Eq. 9, on its strip's edges along one), and the merged layout's aisles turned
into the problem's corridors with the egress measured and checked (`verify.egress`)."""

from __future__ import annotations

import math
import statistics

import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.base import BaseGeometry

from floorplan.models import (
    ConstraintCheck,
    Corridor,
    Egress,
    Layout,
    Problem,
    Report,
    Termination,
)
from floorplan.solver.geometry import boundary_edges
from floorplan.solver.pipeline.regions.corridors import CorridorPlan, planned_dead_ends
from floorplan.solver.verify.checker import SOFT_KINDS
from floorplan.solver.verify.egress import door_travel, route_walk

#: Metres of slack on the travel and dead-end checks: the raster's own error.
MEASURE_SLACK = 0.2


def onto_corridors(sub: Problem, corridors: BaseGeometry) -> Problem:
    """The part's problem with every room that names no exterior wall of its own asked
    to touch one of the part's edges lying along a corridor (C_boundary, Eq. 9). On
    office-154 this left 1 room of 154 without a door onto a corridor instead of 5-7,
    for twice the time (bench/NOTES.md, "Corridors")."""
    grown = corridors.buffer(1e-4, join_style="mitre")
    along = [e.index for e in boundary_edges(sub.boundary)
             if grown.contains(LineString([e.start, e.end]))]
    if not along:
        return sub
    return sub.model_copy(update={"rooms": [
        r if r.boundary else r.model_copy(update={"boundary": list(along)})
        for r in sub.rooms]})


def all_on_corridor(layout: Layout, corridors: BaseGeometry, door: float) -> bool:
    """Every room of `layout` shares at least a door's width of wall with `corridors`."""
    grown = corridors.buffer(1e-4, join_style="mitre")
    return all(
        Polygon(r.polygon).boundary.intersection(grown).length >= door - 1e-6
        for r in layout.rooms
    )


def no_corridors(problem: Problem, seconds: float) -> Layout:
    """The answer when the network IP found no corridor network in its time."""
    check = ConstraintCheck(
        kind="corridors",
        rooms=[],
        satisfied=False,
        detail="no corridor network meets the exits, travel distance"
        + (", dead-end and route" if problem.corridors and problem.corridors.routes
           else " and dead-end")
        + " limits (or none was found in the time)",
    )
    return Layout(
        name=problem.name,
        report=Report(
            coverage=0.0,
            uncovered_area=float(problem.free_area().area),
            constraints=[check],
            solve_time=seconds,
            termination=Termination.NO_SOLUTION,
            valid=False,
        ),
    )


def with_corridors(problem: Problem, layout: Layout, plan: CorridorPlan) -> Layout:
    """`layout`'s aisles as the problem's corridors (doors renamed), and its report with
    the egress measured on the plan and checked against the problem's limits."""
    corridors = problem.corridors
    assert corridors is not None
    names = {a.id: f"corridor-{k + 1}" for k, a in enumerate(layout.aisles)}
    shapes = [Polygon(a.polygon) for a in layout.aisles]
    items = [
        Corridor(
            id=names[a.id],
            polygon=a.polygon,
            rectangles=a.rectangles,
            area=a.area,
            width=corridors.width,
        )
        for a in layout.aisles
    ]
    doors = [
        d.model_copy(update={"between": tuple(names.get(n, n) for n in d.between)})
        for d in layout.doors
    ]
    union = shapely.union_all(shapes) if shapes else Polygon()
    onto: dict[str, list[tuple[tuple[float, float], tuple[float, float]]]] = {}
    for door in doors:
        a, b = door.between
        if a in names.values():
            onto.setdefault(b, []).append(door.segment)
    travel = door_travel(union, corridors.exits, onto) if onto else {}
    finite = [t for t in travel.values() if math.isfinite(t)]
    dead = planned_dead_ends(plan, corridors.width)
    free = float(problem.free_area().area)
    room_ids = [r.id for r in layout.rooms]
    without = [r for r in room_ids if r not in onto]
    unreached = [
        f"{x:g},{y:g}" for x, y in corridors.exits if union.distance(shapely.Point(x, y)) > 1e-3
    ]
    walks = [route_walk(union, *route.between) for route in corridors.routes]
    egress = Egress(
        max_travel=round(max(finite), 3) if finite else None,
        mean_travel=round(statistics.fmean(finite), 3) if finite else None,
        travel={k: round(v, 3) for k, v in travel.items() if math.isfinite(v)},
        dead_ends=[round(d, 3) for d in dead],
        corridor_area=round(float(union.area), 3),
        corridor_share=round(float(union.area) / free, 4) if free else 0.0,
        rooms_without_access=without,
        unreached_exits=unreached,
        routes=[None if not math.isfinite(w) else round(w, 3) for w in walks],
    )
    checks = [_renamed(c) for c in layout.report.constraints]
    checks.append(
        ConstraintCheck(
            kind="corridors",
            rooms=[],
            satisfied=not unreached,
            detail="the corridors reach every exit"
            if not unreached
            else f"no corridor reaches exit(s) {', '.join(unreached)}",
        )
    )
    if corridors.max_travel is not None:
        far = [r for r, t in travel.items() if t > corridors.max_travel + MEASURE_SLACK]
        checks.append(
            ConstraintCheck(
                kind="max_travel",
                rooms=far,
                satisfied=not far,
                detail=f"longest walk from a door to an exit {egress.max_travel} m "
                f"(limit {corridors.max_travel:g} m)",
            )
        )
    if corridors.dead_ends is not None:
        long = [d for d in dead if d > corridors.dead_ends + MEASURE_SLACK]
        checks.append(
            ConstraintCheck(
                kind="dead_ends",
                rooms=[],
                satisfied=not long,
                detail=f"longest dead end {max(dead, default=0.0):.2f} m "
                f"(limit {corridors.dead_ends:g} m)",
            )
        )
    for route, walk in zip(corridors.routes, walks, strict=True):
        (ax, ay), (bx, by) = route.between
        limit = math.inf if route.max_walk is None else route.max_walk + MEASURE_SLACK
        checks.append(
            ConstraintCheck(
                kind="route",
                rooms=[],
                satisfied=walk <= limit,
                detail=f"walk from {ax:g},{ay:g} to {bx:g},{by:g} along the corridors "
                + (f"{walk:.1f} m" if math.isfinite(walk) else "impossible: no corridor "
                   "joins them")
                + ("" if route.max_walk is None else f" (limit {route.max_walk:g} m)"),
            )
        )
    soft = SOFT_KINDS | (set() if corridors.rooms_open_onto_corridor else {"corridor_access"})
    valid = all(c.satisfied for c in checks if c.kind not in soft)
    report = layout.report.model_copy(
        update={"constraints": checks, "egress": egress, "valid": valid}
    )
    return layout.model_copy(
        update={"aisles": [], "corridors": items, "doors": doors, "report": report}
    )


def _renamed(check: ConstraintCheck) -> ConstraintCheck:
    """The aisle checks speak of corridors here; `corridor_access` is hard when rooms
    must open onto a corridor (it is the pipeline's `aisle_access`)."""
    kinds = {"aisle": "corridor", "aisle_access": "corridor_access"}
    if check.kind not in kinds:
        return check
    detail = check.detail.replace("aisles", "corridors").replace("aisle", "corridor")
    return check.model_copy(update={"kind": kinds[check.kind], "detail": detail})
