"""Large layouts, the whole (paper Sec. 5.3, end; Fig. 8): the region layout, the aisles, one
ordinary problem per region part, and the merge with its doors and check."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from floorplan.models import (
    Aisle,
    ConstraintCheck,
    Layout,
    Problem,
    Region,
    Report,
    Room,
    RoomLayout,
    Termination,
)
from floorplan.solver.budget import default_time_limit
from floorplan.solver.events import EventSink, Phase, Solve, SolveEvent
from floorplan.solver.geometry import (
    Box,
    make_domain,
    polygon_coords,
    rectangles_of,
    room_polygon,
)
from floorplan.solver.heuristics.slicing import slicing_has_demands
from floorplan.solver.openings import (
    place_windows,
    requested_doors,
)
from floorplan.solver.pipeline.regions.aisles import AisleNetwork, aisle_network, aisle_pieces
from floorplan.solver.pipeline.regions.bands import band_regions
from floorplan.solver.pipeline.regions.corridor_rooms import (
    all_on_corridor,
    no_corridors,
    onto_corridors,
    with_corridors,
)
from floorplan.solver.pipeline.regions.corridors import CorridorPlan, plan_corridors
from floorplan.solver.pipeline.regions.doors import (
    aisle_doors,
    entrance_door,
    through_doors,
    walk_aisles,
)
from floorplan.solver.pipeline.regions.partition import partition, region_problem, rooms_only
from floorplan.solver.pipeline.regions.parts import points_kept, region_jobs, room_problem
from floorplan.solver.verify.checker import SOFT_KINDS, check_aisles, check_layout
from floorplan.solver.verify.precheck import find_impossibilities

#: Share of the time limit the region layout may use ...
REGION_SHARE = 0.2
#: ... and at most this many seconds per region: slicing lays the regions out at once
#: and the search after it rarely improves on that (measured: 0 of 8 steps on a 154-room
#: office floor; bench/NOTES.md, "Regions and aisles").
REGION_SECONDS_PER_REGION = 0.25
#: ... and at least this many seconds.
MIN_REGION_SECONDS = 1.0
#: When the user's regions got no layout in that time (the time ran out, not the
#: constraints: a loaded machine, regions slicing cannot lay out), the region layout is
#: solved again in this share of the time left, the rest kept for the parts; an automatic
#: partition is solved without regions instead.
REGION_RETRY_SHARE = 0.5
#: The least time (s) a room sub-problem is given ...
MIN_PART_SECONDS = 0.15
#: ... and, when its rooms ask for sizes and guide points only, at most this many
#: seconds per room on top: slicing lays a part's rows out in a fraction of a second,
#: and the search after it found nothing better on a 154-room office floor or a 140-room
#: mall (bench/NOTES.md, "Regions and aisles").
PART_SECONDS_PER_ROOM = 0.01
#: A part whose rooms must open onto its corridor is retried with this many shares of
#: the time (at most a third of the time left) before it gives anything up.
CORRIDOR_RETRY_SHARES = 3.0
#: Time kept per room for merging, doors and the check.
FINISH_SECONDS_PER_ROOM = 0.01
#: What a room sub-problem gives up, in turn, when it finds no layout (model fields
#: set to None; `positions` and `boundary` become empty).
RELAXATIONS: tuple[tuple[str, ...], ...] = (("aspect_ratio",), ("min_size",))



@dataclass
class _Progress:
    """Events of the inner solves passed on, named after the stage."""

    on_event: EventSink | None
    started: float
    placed: dict[str, list[Box]] = field(default_factory=dict)

    def sink(self, stage: str, *, incumbents: bool) -> EventSink | None:
        if self.on_event is None:
            return None

        def forward(event: SolveEvent) -> None:
            assert self.on_event is not None
            rooms = event.rooms
            if event.phase is Phase.INCUMBENT:
                if not incumbents or rooms is None:
                    return
                rooms = self.placed | rooms
            if event.phase is Phase.DONE:
                return
            self.on_event(replace(event, elapsed=time.monotonic() - self.started,
                                  detail=f"{stage}: {event.detail}", rooms=rooms))
        return forward

    def say(self, detail: str, *, subdomain: int = 0, subdomains: int = 0) -> None:
        if self.on_event is None:
            return
        self.on_event(SolveEvent(phase=Phase.LEVEL, level=1,
                                 elapsed=time.monotonic() - self.started, detail=detail,
                                 subdomain=subdomain, subdomains=subdomains))


def solve_regions(
    problem: Problem,
    *,
    solve: Solve,
    on_event: EventSink | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> Layout:
    """Lay out `problem` through regions and aisles (module docstring); the region
    layout and each part are laid out by `solve`."""
    started = time.monotonic()
    flat = rooms_only(problem)
    if find_impossibilities(flat, make_domain(flat)):
        return solve(flat, on_event=on_event, should_stop=should_stop)
    limit = problem.options.time_limit or default_time_limit(len(problem.rooms))
    deadline = started + limit - min(limit * 0.1, FINISH_SECONDS_PER_ROOM * len(problem.rooms))
    progress = _Progress(on_event, started)
    plan: CorridorPlan | None = None
    terminations: list[Termination] = []
    levels = 1
    given: Sequence[Region] = ()
    if problem.corridors is not None:
        # Corridors from what they must do: the network IP's corridors, blocks between.
        plan = plan_corridors(problem, limit, problem.options.seed or 0,
                              late=problem.options.time_limit is None)
        if plan is None:
            return no_corridors(problem, time.monotonic() - started)
        progress.say(f"corridors: {len(plan.result.edges)} network edges "
                     f"({plan.result.status}), {plan.shape.area:.1f} m², "
                     f"{len(plan.blocks)} blocks"
                     + (", grid widened where a strip fitted no room" if plan.widened else ""))
        shapes: dict[str, Polygon] = dict(plan.blocks)
        network = plan.network
    else:
        bands = band_regions(problem) if problem.regions is None else None
        if bands is not None:
            # An automatic partition: bars of rooms along aisles, planned.
            shapes = dict(bands)
            progress.say(f"regions: {len(shapes)} bars of rooms along aisles")
        else:
            given = partition(problem)
            progress.say(f"regions: {len(given)} regions of "
                         f"{', '.join(str(len(g.rooms)) for g in given)} rooms")
            laid = _region_layout(problem, given, limit, deadline, solve, progress,
                                  should_stop)
            if not laid.rooms:
                if problem.regions is None and not (should_stop and should_stop()):
                    # An automatic partition is only a means: solve flat instead.
                    progress.say("regions: no region layout, solving without regions")
                    return solve(flat.with_options(
                        time_limit=max(1.0, deadline - time.monotonic())),
                        on_event=on_event, should_stop=should_stop)
                report = laid.report.model_copy(
                    update={"solve_time": time.monotonic() - started})
                return Layout(name=problem.name, report=report)
            shapes = {r.id: Polygon(r.polygon) for r in laid.rooms}
            terminations.append(laid.report.termination)
            levels = laid.report.levels
        network = _aisles(problem, given, shapes, progress)
    jobs = region_jobs(problem, list(shapes), given, network,
                       plan.capacity if plan is not None else None,
                       plan.fit if plan is not None else None,
                       plan.most if plan is not None else None)
    placed: dict[str, list[Box]] = {}
    owner: dict[str, str] = {}
    left_rooms = len(problem.rooms)
    for k, (region_id, part, rooms) in enumerate(jobs):
        if should_stop is not None and should_stop():
            break
        share = max(MIN_PART_SECONDS, (deadline - time.monotonic()) * len(rooms) / left_rooms)
        left_rooms -= len(rooms)
        stage = f"region {region_id} {k + 1}/{len(jobs)}"
        progress.say(stage, subdomain=k + 1, subdomains=len(jobs))
        inner = _solve_part(problem, part, rooms, share, deadline, left_rooms, stage, solve,
                            progress, should_stop,
                            facing=plan.shape if plan is not None else None)
        terminations.append(inner.report.termination)
        levels = max(levels, inner.report.levels)
        for room in inner.rooms:
            placed[room.id] = [Box.of(rect) for rect in room.rectangles]
            owner[room.id] = region_id
        progress.placed = dict(placed)
    stopped = should_stop is not None and should_stop()
    merged = _merge(problem, list(shapes), network, placed, owner,
                    Termination.of_parts(terminations, interrupted=stopped), levels, started,
                    progress)
    return merged if plan is None else with_corridors(problem, merged, plan)


def _aisles(problem: Problem, given: Sequence[Region], shapes: dict[str, Polygon],
            progress: _Progress) -> AisleNetwork:
    """Step 3: the walls the regions share widened into aisles reaching the entrance,
    kept off the guide points of each region's rooms."""
    keep = points_kept(problem, given, shapes)
    network = aisle_network(problem.free_area(), problem.outline(), shapes,
                            problem.aisle_width, entrance=problem.entrance, keep=keep)
    progress.say(f"aisles: {len(network.pieces)} aisle(s), "
                 f"{network.union.area:.1f} m²")
    return network


def _region_layout(problem: Problem, given: Sequence[Region], limit: float, deadline: float,
                   solve: Solve, progress: _Progress,
                   should_stop: Callable[[], bool] | None) -> Layout:
    """The user's regions laid out as the rooms of a first problem (step 2), in a short
    share of the time; when that found nothing and the time ran out, the user's regions
    are solved again in `REGION_RETRY_SHARE` of the time left (an automatic partition
    falls back on a solve without regions instead, in `solve_regions`)."""
    level_one = region_problem(problem, given, max(MIN_REGION_SECONDS, min(
        limit * REGION_SHARE, REGION_SECONDS_PER_REGION * len(given))))
    laid = solve(level_one, on_event=progress.sink("regions", incumbents=False),
                 should_stop=should_stop)
    longer = (deadline - time.monotonic()) * REGION_RETRY_SHARE
    if (problem.regions is not None and not laid.rooms
            and laid.report.termination is Termination.NO_SOLUTION
            and longer > level_one.options.time_limit
            and not (should_stop is not None and should_stop())):
        progress.say(f"regions: no layout yet, retrying with {longer:.1f} s")
        laid = solve(level_one.with_options(time_limit=longer),
                     on_event=progress.sink("regions", incumbents=False),
                     should_stop=should_stop)
    return laid


def _solve_part(
    problem: Problem, part: Polygon, rooms: list[Room], share: float, deadline: float,
    left_rooms: int, stage: str, solve: Solve, progress: _Progress,
    should_stop: Callable[[], bool] | None, *, facing: BaseGeometry | None = None,
) -> Layout:
    """One region part's rooms (step 4) in its `share` of the time; retried with the
    part's whole share when the time ran out, then without what cannot hold there.
    `left_rooms` counts the rooms of the parts after this one. `facing`: the corridors,
    which each room must touch when the problem asks (given up last)."""
    sub = room_problem(problem, part, rooms, share)
    relaxations = RELAXATIONS
    corridors = problem.corridors
    if facing is not None and corridors is not None and corridors.rooms_open_onto_corridor:
        if not slicing_has_demands(sub):
            # Slicing alone first: a strip one cell deep mostly gets one row, every room
            # on the corridor, at once; C_boundary on all 21 rooms of office-154's
            # 66 m strip found no layout in 8 s (bench/NOTES.md, "Corridors").
            plain = solve(sub.with_options(time_limit=min(
                share, MIN_PART_SECONDS + PART_SECONDS_PER_ROOM * len(rooms))),
                should_stop=should_stop)
            if len(plain.rooms) == len(rooms) and all_on_corridor(
                    plain, facing, problem.openings.door_width):
                return plain
        sub = onto_corridors(sub, facing)
        relaxations = (*RELAXATIONS, ("boundary",))
    if not slicing_has_demands(sub):
        # Sizes alone: slicing lays the rows out at once and the search after it
        # does not pay for its time (measured: no step improved in most parts of a
        # 154-room office floor; bench/NOTES.md, "Regions and aisles").
        sub = sub.with_options(time_limit=min(
            share, MIN_PART_SECONDS + PART_SECONDS_PER_ROOM * len(rooms)))
    inner = solve(sub, on_event=progress.sink(stage, incumbents=True),
                  should_stop=should_stop)
    longer = max(share, (deadline - time.monotonic()) * len(rooms)
                 / (left_rooms + len(rooms)))
    if facing is not None:
        # Rooms asked onto a corridor are worth more time before one loses its door
        # (mall-140's deep west column: 12 rooms in one row found in 5 s, not in 1.9 s).
        longer = max(longer, min(CORRIDOR_RETRY_SHARES * share,
                                 (deadline - time.monotonic()) / 3))
    if (not inner.rooms and inner.report.termination is Termination.NO_SOLUTION
            and longer > sub.options.time_limit
            and not (should_stop is not None and should_stop())):
        # The time ran out, not the constraints (a loaded machine, a part slicing
        # cannot lay out): the part's whole share before anything is given up.
        progress.say(f"{stage}: no layout yet, retrying with {longer:.1f} s")
        sub = sub.with_options(time_limit=longer)
        inner = solve(sub, on_event=progress.sink(stage, incumbents=True),
                      should_stop=should_stop)
    for relax in relaxations:
        if inner.rooms or (should_stop is not None and should_stop()):
            break
        # A part the region layout made awkward: keep the rooms, give up what
        # cannot hold there; the final check reports it against the user's problem.
        progress.say(f"{stage}: no layout, retrying without {', '.join(relax)}")
        sub = sub.model_copy(update={"rooms": [
            r.model_copy(update={k: [] if k == "boundary" else None for k in relax})
            for r in sub.rooms]})
        sub = sub.with_options(time_limit=max(MIN_PART_SECONDS, share / 2))
        inner = solve(sub, should_stop=should_stop)
    return inner


def _merge(problem: Problem, region_ids: Sequence[str], network: AisleNetwork,
           placed: Mapping[str, list[Box]], owner: Mapping[str, str],
           termination: Termination, levels: int, started: float,
           progress: _Progress) -> Layout:
    """One layout of every room and aisle, with doors, windows and the checks."""
    flat = rooms_only(problem)
    network = _with_leftovers(problem, network, placed)
    aisles = [Aisle(id=f"aisle-{k + 1}", polygon=polygon_coords(p.polygon),
                    rectangles=[b.to_rect() for b in rectangles_of(p.polygon)],
                    area=round(float(p.polygon.area), 6), width=problem.aisle_width,
                    regions=list(p.regions))
              for k, p in enumerate(network.pieces)]
    aisle_shapes = {a.id: p.polygon for a, p in zip(aisles, network.pieces, strict=True)}
    check = check_layout(flat, placed, aisles=list(aisle_shapes.values()))
    polygons = {r.id: room_polygon(placed[r.id]) for r in problem.rooms if r.id in placed}
    members = {g: [r for r in placed if owner.get(r) == g] for g in region_ids}
    aisle_checks = check_aisles(problem, polygons, aisle_shapes, members)
    doors = requested_doors(flat, polygons)
    doors += aisle_doors(problem, polygons, aisle_shapes)
    entry = entrance_door(problem, polygons, aisle_shapes)
    if entry is not None:
        doors.append(entry)
    doors += through_doors(problem, polygons, aisle_shapes, doors)
    windows = place_windows(flat, polygons, doors)
    circulation = walk_aisles(problem, doors, aisle_shapes)
    access = [r.id for r in problem.rooms if r.id in polygons and not any(
        d.between == (a, r.id) for d in doors for a in aisle_shapes)]
    constraints = [*check.constraints, *aisle_checks, ConstraintCheck(
        kind="aisle_access", rooms=access, satisfied=not access,
        detail="every room has a door onto an aisle" if not access else
        f"{len(access)} room(s) reached through a neighbour, not from an aisle")]
    valid = all(c.satisfied for c in constraints if c.kind not in SOFT_KINDS)
    w = problem.weights
    objective = w.cover * check.uncovered_area + w.size * sum(check.size_error.values())
    rooms = [RoomLayout(id=r.id, type=r.type, polygon=polygon_coords(polygons[r.id]),
                        rectangles=[b.to_rect() for b in placed[r.id]],
                        area=round(float(polygons[r.id].area), 6), region=owner.get(r.id))
             for r in problem.rooms if r.id in polygons]
    report = Report(coverage=check.coverage, uncovered_area=check.uncovered_area,
                    constraints=constraints, size_error=check.size_error, objective=objective,
                    levels=levels, solve_time=time.monotonic() - started,
                    termination=termination, valid=valid, circulation=circulation)
    if progress.on_event is not None:
        progress.on_event(SolveEvent(phase=Phase.DONE, level=levels,
                                     elapsed=time.monotonic() - started, objective=objective,
                                     detail=f"coverage {check.coverage:.1%} (aisles included)"))
    return Layout(name=problem.name, rooms=rooms, doors=doors, windows=windows, aisles=aisles,
                  report=report)


def _with_leftovers(problem: Problem, network: AisleNetwork,
                    placed: Mapping[str, list[Box]]) -> AisleNetwork:
    """Floor a region's rooms left uncovered where it opens onto an aisle widens that
    aisle (an alcove), rather than staying a gap in the plan."""
    rooms = shapely.union_all([b.to_polygon() for boxes in placed.values() for b in boxes])
    current = network.union
    left = problem.free_area().difference(rooms).difference(current)
    extra = [p for p in getattr(left, "geoms", [left]) if isinstance(p, Polygon)
             and p.area > 1e-3 and p.boundary.intersection(current.boundary).length > 0.1]
    if not extra:
        return network
    grown = aisle_pieces([*(p.polygon for p in network.pieces), *extra], problem.free_area(),
                         {}, keep_regions=[p.regions for p in network.pieces])
    return AisleNetwork(grown, network.parts)
