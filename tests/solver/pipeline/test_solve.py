"""End-to-end behaviour of `solve`: real SCIP, small problems, small time limits."""

from __future__ import annotations

import itertools
import json
import random
import time
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from floorplan.models import Problem, Termination
from floorplan.solver import solve
from floorplan.solver.events import Phase, SolveEvent
from floorplan.solver.geometry import Box, make_domain, shared_wall_length
from floorplan.solver.heuristics.level_one import FIRST_BAND, level_one_spec, target_bands
from floorplan.solver.miqp.formulation import build_level
from floorplan.solver.miqp.objective import e_band_shortfall
from floorplan.solver.miqp.scip_run import LevelStatus, run_level
from floorplan.solver.verify.checker import CheckResult, check_layout
from tests.paths import EXAMPLES


def problem(**fields: Any) -> Problem:
    return Problem.model_validate(fields)


L_SHAPE_WITH_OBSTACLE = problem(
    name="l-shape",
    boundary=[[0, 0], [8, 0], [8, 4], [4, 4], [4, 8], [0, 8]],
    obstacles=[{"x": 1, "y": 5, "width": 1, "depth": 1, "label": "shaft"}],
    entrance=[2, 0],
    rooms=[
        {"id": "living", "type": "living", "min_size": [2, 2], "max_size": [6, 6],
         "target_size": [4, 4], "positions": [[2, 0.5]]},
        {"id": "kitchen", "type": "kitchen", "min_size": [2, 2], "max_size": [5, 5],
         "target_size": [3, 3], "boundary": ["east"]},
        {"id": "bed", "type": "bedroom", "min_size": [2, 2], "max_size": [5, 5],
         "target_size": [3.5, 3.5], "boundary": ["north"]},
    ],
    adjacency=[{"a": "living", "b": "kitchen"}, {"a": "living", "b": "bed"}],
    options={"time_limit": 4, "seed": 1},
)


def test_hierarchy_covers_an_l_shaped_domain_with_an_obstacle_completely() -> None:
    layout = solve(L_SHAPE_WITH_OBSTACLE)
    report = layout.report
    assert report.valid, [c for c in report.constraints if not c.satisfied]
    assert report.coverage == pytest.approx(1.0, abs=1e-6)
    assert report.uncovered_area == pytest.approx(0.0, abs=1e-4)
    # The shaft can only be covered around: some room is not a rectangle.
    assert any(len(r.polygon) > 4 for r in layout.rooms)
    for room in layout.rooms:
        assert room.area > 0
        assert _counter_clockwise(room.polygon)


def _counter_clockwise(ring: list[tuple[float, float]]) -> bool:
    edges = zip(ring, ring[1:] + ring[:1], strict=True)
    twice_area = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in edges)
    return twice_area > 0


def test_report_agrees_with_an_independent_check_of_the_returned_rectangles() -> None:
    layout = solve(L_SHAPE_WITH_OBSTACLE)
    rooms = {r.id: [Box.of(rect) for rect in r.rectangles] for r in layout.rooms}
    again = check_layout(L_SHAPE_WITH_OBSTACLE, rooms)
    assert again.valid == layout.report.valid
    assert again.coverage == pytest.approx(layout.report.coverage)
    assert [c.satisfied for c in again.constraints] == [
        c.satisfied for c in layout.report.constraints
    ]


def test_progress_events_report_levels_and_a_final_done() -> None:
    events: list[SolveEvent] = []
    solve(L_SHAPE_WITH_OBSTACLE, on_event=events.append)
    phases = [e.phase for e in events]
    assert phases[0] is Phase.LEVEL and phases[-1] is Phase.DONE
    assert Phase.INCUMBENT in phases
    ids = {r.id for r in L_SHAPE_WITH_OBSTACLE.rooms}
    for event in (e for e in events if e.phase is Phase.INCUMBENT):
        assert event.rooms is not None and set(event.rooms) == ids
        assert event.objective is not None and event.objective >= 0
    assert all(b.elapsed >= a.elapsed for a, b in itertools.pairwise(events))


TWELVE_OFFICES = problem(
    name="offices",
    # A little more floor than the targets ask: no exact tiling ends the solve at once.
    boundary=[[0, 0], [16.2, 0], [16.2, 9], [0, 9]],
    rooms=[{"id": f"office{k}", "min_size": [2, 2], "max_size": [6, 6],
            "target_size": [4.1 - 0.1 * (k % 3), 3.0]} for k in range(12)],
    options={"time_limit": 60},
)


def test_should_stop_interrupts_and_keeps_the_best_layout_so_far() -> None:
    # Asked to stop at the first incumbent (its 60 s would go to the neighbourhood
    # search and the reshaping, which never start).
    events: list[SolveEvent] = []
    layout = solve(TWELVE_OFFICES, on_event=events.append,
                   should_stop=lambda: any(e.phase is Phase.INCUMBENT for e in events))
    assert layout.report.termination is Termination.INTERRUPTED
    assert not [e.detail for e in events
                if e.detail.startswith(("neighbourhood search", "reshaping"))]
    assert layout.report.valid
    assert len(layout.rooms) == 12


@pytest.mark.parametrize(
    ("fields", "finding"),
    [
        ({"rooms": [{"id": "a", "min_size": [3, 3]}, {"id": "b", "min_size": [3, 3]}]},
         "minimum sizes need"),
        ({"rooms": [{"id": "a", "min_size": [5, 1]}]}, "bounding box"),
        ({"rooms": [{"id": "a", "min_size": [5, 1], "max_rects": 1}]}, "fits nowhere"),
        ({"rooms": [{"id": "a"}, {"id": "b"}], "adjacency": [{"a": "a", "any_of": ["a"]}]},
         "touch itself"),
        ({"rooms": [{"id": "a", "min_size": [1, 1], "max_size": [1.5, 1.5],
                     "aspect_ratio": [2, 3]}]}, "aspect ratio"),
        ({"rooms": [{"id": "a", "max_size": [1, 1], "positions": [[0.5, 0.5], [3.5, 3.5]]}]},
         "both its positions"),
    ],
)
def test_cheap_impossibilities_are_reported_before_solving(
    fields: dict[str, Any], finding: str
) -> None:
    p = problem(boundary=[[0, 0], [4, 0], [4, 4], [0, 4]], **fields)
    layout = solve(p)
    assert layout.report.termination is Termination.INFEASIBLE
    assert layout.rooms == []
    assert layout.report.infeasibility is not None
    assert any(finding in f for f in layout.report.infeasibility.findings)


def test_infeasibility_proved_by_scip_names_families_and_relaxations() -> None:
    # Each room fits alone, the areas add up, but three rectangles of at least 2.6 m
    # square cannot share a 5 x 5 square without overlapping.
    p = problem(
        boundary=[[0, 0], [5, 0], [5, 5], [0, 5]],
        rooms=[{"id": k, "min_size": [2.6, 2.6], "max_size": [4.5, 4.5], "target_size": [3, 3],
                "max_rects": 1} for k in "abc"],
        options={"time_limit": 5},
    )
    layout = solve(p)
    report = layout.report
    assert report.termination is Termination.INFEASIBLE
    assert report.infeasibility is not None
    assert "C_overlap" in report.infeasibility.active_families
    assert report.infeasibility.relaxations_tried[-1].startswith("user bounds")
    assert len(report.infeasibility.relaxations_tried) > 1


@pytest.mark.slow
def test_same_seed_gives_the_same_layout_on_a_small_problem() -> None:
    first = solve(L_SHAPE_WITH_OBSTACLE)
    second = solve(L_SHAPE_WITH_OBSTACLE)
    if first.report.termination is Termination.OPTIMAL:
        assert [r.rectangles for r in first.rooms] == [r.rectangles for r in second.rooms]
    else:  # bounded by wall-clock time: only the quality is comparable
        assert second.report.valid == first.report.valid


# Property: every problem read off a real partition is solved validly.


@st.composite
def partitioned_problems(draw: st.DrawFn) -> Problem:
    """Cut a rectangle into 2-5 rooms by random guillotine cuts, then ask for what the
    partition shows: sizes around each room's, shared walls as adjacencies, touched
    edges as boundary constraints, room centres as positions. Feasible by construction."""
    seed = draw(st.integers(0, 10_000))
    count = draw(st.integers(2, 5))
    rng = random.Random(seed)
    width, depth = rng.choice([6.0, 8.0, 10.0]), rng.choice([5.0, 6.0, 8.0])
    boxes = [Box(0, 0, width, depth)]
    while len(boxes) < count:
        boxes.sort(key=lambda b: b.area)
        b = boxes.pop()
        if b.width >= b.depth:
            cut = round(b.x0 + b.width * rng.uniform(0.35, 0.65), 1)
            boxes += [Box(b.x0, b.y0, cut, b.y1), Box(cut, b.y0, b.x1, b.y1)]
        else:
            cut = round(b.y0 + b.depth * rng.uniform(0.35, 0.65), 1)
            boxes += [Box(b.x0, b.y0, b.x1, cut), Box(b.x0, cut, b.x1, b.y1)]
    rooms = []
    for k, b in enumerate(boxes):
        room: dict[str, Any] = {
            "id": f"r{k}",
            "min_size": [round(b.width * 0.7, 2), round(b.depth * 0.7, 2)],
            "max_size": [round(b.width * 1.3, 2), round(b.depth * 1.3, 2)],
            "target_size": [b.width, b.depth],
        }
        if rng.random() < 0.4:
            room["positions"] = [[(b.x0 + b.x1) / 2, (b.y0 + b.y1) / 2]]
        touched = [name for name, hit in (("south", b.y0 == 0), ("north", b.y1 == depth),
                                          ("west", b.x0 == 0), ("east", b.x1 == width)) if hit]
        if touched and rng.random() < 0.5:
            room["boundary"] = [rng.choice(touched)]
        rooms.append(room)
    adjacency = [
        {"a": f"r{i}", "b": f"r{j}", "min_contact": 0.9}
        for i in range(len(boxes)) for j in range(i + 1, len(boxes))
        if shared_wall_length(boxes[i].to_polygon(), boxes[j].to_polygon()) >= 1.5
        and rng.random() < 0.6
    ]
    return problem(
        name=f"partition-{seed}",
        boundary=[[0, 0], [width, 0], [width, depth], [0, depth]],
        rooms=rooms, adjacency=adjacency,
        options={"time_limit": 2, "seed": seed % 7, "max_levels": 2},
    )


@pytest.mark.slow
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(partitioned_problems())
def test_solved_layouts_of_feasible_problems_always_pass_the_checker(p: Problem) -> None:
    layout = solve(p)
    report = layout.report
    assert report.termination not in (Termination.INFEASIBLE, Termination.NO_SOLUTION)
    assert report.valid, [c for c in report.constraints if not c.satisfied]
    assert {r.id for r in layout.rooms} == {r.id for r in p.rooms}


@pytest.mark.slow
@pytest.mark.parametrize(("rows_up_to", "start", "limit"), [
    # Rows of columns honour its adjacencies and walls. A limit far above the need (the
    # stall rule ends the solve): on a busy machine the row search needs more than its
    # share of a short one.
    (40, "sliced into rows: found", 40),
    # Without the row search: the batch construction, at once; the layout it leads to
    # does not cover the floor, so no stall ends the solve before its limit.
    (0, "built in batches: found", 8),
])
def test_problems_above_twenty_rooms_get_a_constructive_start_and_come_back_valid(
    rows_up_to: int, start: str, limit: float, monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr("floorplan.solver.heuristics.slicing.DEMANDS_UP_TO", rows_up_to)
    rooms = [{"id": f"cell{k:02d}", "type": "office", "min_size": [1.8, 1.8],
              "max_size": [4, 4], "target_size": [2.5, 2.5]} for k in range(24)]
    rooms[0]["positions"] = [[0.5, 0.5]]
    rooms[1]["boundary"] = ["north"]
    p = problem(
        name="cells", boundary=[[0, 0], [15, 0], [15, 10], [0, 10]],
        obstacles=[{"x": 6, "y": 4, "width": 2, "depth": 2}], rooms=rooms,
        adjacency=[{"a": f"cell{k:02d}", "b": f"cell{k + 1:02d}"} for k in range(2, 10, 2)],
        options={"time_limit": limit, "seed": 3},
    )
    events: list[SolveEvent] = []
    layout = solve(p, on_event=events.append)
    assert any(start in e.detail for e in events)
    assert layout.report.valid, [c for c in layout.report.constraints if not c.satisfied]
    assert layout.report.coverage > 0.8


def test_rectangles_that_do_not_join_fail_a_check_instead_of_raising() -> None:
    from floorplan.solver.geometry import Box
    from floorplan.solver.pipeline.assemble import outline_of

    polygon = outline_of([Box(0, 0, 2, 2), Box(2.001, 0, 4, 1)])
    assert polygon.area == pytest.approx(4.0)  # the larger part stands for the room
    p = problem(boundary=[[0, 0], [4, 0], [4, 2], [0, 2]], rooms=[{"id": "a"}])
    checks = check_layout(p, {"a": [Box(0, 0, 2, 2), Box(2.001, 0, 4, 1)]})
    assert not checks.valid
    assert any(c.kind == "connected" and not c.satisfied for c in checks.constraints)


@pytest.mark.slow
def test_require_connected_returns_a_plan_where_every_room_is_reachable() -> None:
    # Left to itself the storage room ends up with no wall its door policy allows
    # (its one adjacency is to a bedroom); the demands put it next to the hall or foyer.
    data = json.loads((EXAMPLES / "apartment-15-obstacles.json").read_text())
    # A limit far above the need (the stall rule ends the solve): under load (three test
    # processes on two cores) 10 s once ended on a layout with a room outside the floor,
    # reported invalid.
    data["options"] = {"require_connected": True, "time_limit": 60}
    layout = solve(Problem.model_validate(data))
    assert layout.report.valid, [c for c in layout.report.constraints if not c.satisfied]
    assert layout.report.circulation is not None
    assert layout.report.circulation.reachable
    assert not any(c.kind == "circulation" and not c.satisfied
                   for c in layout.report.constraints)


@pytest.mark.slow
def test_every_incumbent_is_announced_as_it_would_be_returned_and_the_end_keeps_coverage(
) -> None:
    # The house of the examples at seed 0 once reached full coverage early, then traded
    # it for size error and ended below the goal; incumbents now carry absorbed gaps, and
    # the best covering one is returned when the last steps lose coverage.
    # Stopped a few incumbents after the first covering one, not at a time: a busy
    # machine gets there later (its 4 s once saw none), and 10 s is the most it runs.
    house = Problem.model_validate_json((EXAMPLES / "house-13.json").read_text())
    house = house.model_copy(update={"options": house.options.model_copy(
        update={"seed": 0, "time_limit": 10.0})})
    checks: list[CheckResult] = []

    def keep(event: SolveEvent) -> None:
        if event.phase is Phase.INCUMBENT and event.rooms is not None:
            checks.append(check_layout(house, event.rooms))

    def covered_a_while() -> bool:
        covering = [check.coverage >= 0.99 for check in checks]
        return True in covering and len(covering) - covering.index(True) > 3

    layout = solve(house, on_event=keep, should_stop=covered_a_while)
    assert checks
    for check in checks:
        assert check.valid, [c for c in check.constraints if not c.satisfied]
    if any(check.coverage >= 0.99 for check in checks):
        assert layout.report.coverage >= 0.99
    assert layout.report.valid


def two_bedrooms(**room: Any) -> Problem:
    """Bedrooms `a` and `b` with 2 x 2 m targets on a 4 x 2 m floor, each with `room`'s
    fields too."""
    return problem(
        name="two", boundary=[[0, 0], [4, 0], [4, 2], [0, 2]],
        rooms=[{"id": r, "type": "bedroom", "min_size": [1, 1], "target_size": [2, 2], **room}
               for r in ("a", "b")])


def test_the_best_covering_incumbent_replaces_a_final_layout_that_lost_coverage() -> None:
    from floorplan.solver.geometry import make_domain
    from floorplan.solver.pipeline.hierarchy import Piece
    from floorplan.solver.pipeline.run import Run

    two = two_bedrooms()
    domain = make_domain(two)
    run = Run(two, deadline=time.monotonic() + 1, started=time.monotonic(), on_event=None,
               should_stop=None)
    full = {"a": [Box(0, 0, 2, 2)], "b": [Box(2, 0, 4, 2)]}
    run.incumbent(domain, full)
    # A final layout that lost coverage (better_of takes it as given, gaps and all).
    shrunk = [Piece("a", "a", Box(0, 0, 2, 2)), Piece("b", "b", Box(2, 0, 3, 1))]
    kept = run.better_of(domain, shrunk)
    assert {p.room: p.box for p in kept} == {"a": Box(0, 0, 2, 2), "b": Box(2, 0, 4, 2)}
    # A final layout that covers and scores no worse stays.
    assert run.better_of(domain, [Piece("a", "a", Box(0, 0, 2, 2)),
                                  Piece("b", "b", Box(2, 0, 4, 2))])[1].box == Box(2, 0, 4, 2)


def test_a_second_level_one_search_that_ends_better_is_returned_with_its_gaps_absorbed(
) -> None:
    from floorplan.solver.pipeline.hierarchy import Piece, room_boxes
    from floorplan.solver.pipeline.run import Run
    from floorplan.solver.pipeline.second_search import better_final
    from floorplan.solver.pipeline.subdomains import LevelOneOutcome

    # A second level-1 search's pieces leave the gaps level 1 leaves; the incumbent it
    # announced had them absorbed, and so must the answer (CI once returned 86 % for
    # an announced 99 %).
    two = two_bedrooms()
    domain = make_domain(two)
    announced: list[SolveEvent] = []
    run = Run(two, deadline=time.monotonic() + 1, started=time.monotonic(),
              on_event=announced.append, should_stop=None)
    mine = [Piece("a", "a", Box(0, 0, 1, 1)), Piece("b", "b", Box(3, 1, 4, 2))]
    second = LevelOneOutcome([Piece("a", "a", Box(0, 0, 2, 2)),
                              Piece("b", "b", Box(2, 0, 4, 1.5))], {}, [], None, False, [])
    final = room_boxes(better_final(run, domain, mine, second))
    assert check_layout(two, final).coverage == pytest.approx(1.0)
    assert [e.rooms for e in announced if e.phase is Phase.INCUMBENT] == [final]
    # A finished layout that covers and scores no worse stays.
    full = [Piece("a", "a", Box(0, 0, 2, 2)), Piece("b", "b", Box(2, 0, 4, 2))]
    assert better_final(run, domain, full, second) == full


def test_levels_that_end_short_of_coverage_get_a_second_round_from_the_reshaping() -> None:
    from floorplan.solver.pipeline.absorb import absorbed
    from floorplan.solver.pipeline.floor import _refined
    from floorplan.solver.pipeline.hierarchy import Piece, room_boxes
    from floorplan.solver.pipeline.run import Run, covers

    # The search time is spent (level 1 took it), so the first round of levels does
    # nothing. `a` and `b` are at their largest widths and leave a strip on the west
    # that no room can absorb, nor `a` moved across it (`b` could not take what `a`
    # leaves): the second round has until `later` to work on it.
    two = two_bedrooms(max_size=[2, 2])
    b = two.rooms[1].model_copy(update={"max_size": (1.5, 2), "target_size": (1.5, 2)})
    two = two.model_copy(update={"rooms": [two.rooms[0], b]})
    domain = make_domain(two)
    pieces = [Piece("a", "a", Box(0.5, 0, 2.5, 2)), Piece("b", "b", Box(2.5, 0, 4, 2))]
    assert not covers(domain, absorbed(two, domain, room_boxes(pieces)))
    announced: list[SolveEvent] = []
    run = Run(two, deadline=time.monotonic(), started=time.monotonic(),
              on_event=announced.append, should_stop=None)
    later = time.monotonic() + 3
    refined, levels = _refined(run, domain, pieces, None, later)
    assert any("another round" in e.detail for e in announced)
    assert run.deadline == later and levels >= 2
    assert {p.room for p in refined} == {"a", "b"}
    # Pieces that cover get no second round and keep the deadline.
    run = Run(two, deadline=time.monotonic(), started=time.monotonic(), on_event=None,
              should_stop=None)
    full = [Piece("a", "a", Box(0, 0, 2, 2)), Piece("b", "b", Box(2, 0, 4, 2))]
    before = run.deadline
    assert _refined(run, domain, full, None, time.monotonic() + 3) == (full, 1)
    assert run.deadline == before


def test_the_reshaping_slides_a_room_at_its_largest_across_a_gap_the_strips_cannot_fill(
) -> None:
    from floorplan.solver.pipeline.hierarchy import Piece, room_boxes
    from floorplan.solver.pipeline.refine import reshaped
    from floorplan.solver.pipeline.run import Run, covers

    # a | b | gap | c across a 9 x 6 floor, b and c at their largest width, a on the
    # west wall and c on the east: no strip fills the gap (b or c would pass its
    # maximum) and a and c cannot trade places, but b sliding east while a grows
    # behind it does, and the layout covers.
    floor = problem(
        name="row", boundary=[[0, 0], [9, 0], [9, 6], [0, 6]],
        rooms=[{"id": "a", "type": "living", "target_size": [3, 6], "boundary": ["west"]},
               {"id": "b", "type": "wc", "target_size": [2, 6], "max_size": [2, 6]},
               {"id": "c", "type": "bedroom", "target_size": [3, 6], "max_size": [3, 6],
                "boundary": ["east"]}])
    domain = make_domain(floor)
    pieces = [Piece("a", "a", Box(0, 0, 3, 6)), Piece("b", "b", Box(3, 0, 5, 6)),
              Piece("c", "c", Box(6, 0, 9, 6))]
    assert not covers(domain, room_boxes(pieces))
    run = Run(floor, deadline=time.monotonic() + 2, started=time.monotonic(),
              on_event=None, should_stop=None)
    after = room_boxes(reshaped(run, domain, pieces, time.monotonic() + 2))
    check = check_layout(floor, after)
    assert check.valid and check.coverage == pytest.approx(1.0)
    assert after["b"] == [Box(4, 0, 6, 6)] and after["c"] == [Box(6, 0, 9, 6)]


def test_a_gap_side_bordered_by_a_room_over_part_of_its_length_is_absorbed_there() -> None:
    from floorplan.solver.geometry import make_domain
    from floorplan.solver.pipeline.absorb import absorb_gaps
    from floorplan.solver.pipeline.hierarchy import Piece, room_boxes

    # The strip above both rooms is one gap cell; only `a` borders part of its south
    # side, and only `a` may grow (to its maximum depth of 2.5).
    floor = problem(
        name="partly", boundary=[[0, 0], [4, 0], [4, 3], [0, 3]],
        rooms=[{"id": "a", "type": "bedroom", "min_size": [1, 1], "max_size": [2, 2.5]},
               {"id": "b", "type": "bedroom", "min_size": [1, 1], "max_size": [2, 1.5]}])
    pieces = [Piece("a", "a", Box(0, 0, 2, 2)), Piece("b", "b", Box(2, 0, 4, 1.5))]
    grown = room_boxes(absorb_gaps(floor, make_domain(floor), pieces))
    assert sum(b.area for b in grown["a"]) == pytest.approx(5.0)
    assert grown["b"] == [Box(2, 0, 4, 1.5)]


# The hall must reach both side rooms, so it is at least 4 m wide against a target of
# 1 m: no window of the schedule (up to target +-100 %) holds.
SPANNING_HALL = problem(
    name="spanning-hall",
    boundary=[[0, 0], [12, 0], [12, 6], [0, 6]],
    obstacles=[{"x": 5, "y": 2.5, "width": 1.5, "depth": 1.5, "label": "stairs"}],
    rooms=[
        {"id": "west", "min_size": [2, 2], "max_size": [4, 6], "target_size": [3, 3],
         "boundary": ["west"]},
        {"id": "east", "min_size": [2, 2], "max_size": [4, 6], "target_size": [3, 3],
         "boundary": ["east"]},
        {"id": "hall", "min_size": [0.9, 0.9], "max_size": [10, 6], "target_size": [1, 3]},
        {"id": "a", "min_size": [1, 1], "max_size": [8, 6], "target_size": [3, 2.5]},
        {"id": "b", "min_size": [1, 1], "max_size": [8, 6], "target_size": [3, 2.5]},
    ],
    adjacency=[{"a": "hall", "b": "west"}, {"a": "hall", "b": "east"}],
    options={"time_limit": 3, "seed": 0},
)


def test_first_layout_under_the_users_bounds_keeps_rooms_within_their_target_bands(
) -> None:
    # As `solve` builds it once the window schedule is exhausted (solver/pipeline/first_layout.py).
    domain = make_domain(SPANNING_HALL)
    lm = build_level(level_one_spec(SPANNING_HALL, domain, window=None), feasibility=True)
    bands = target_bands(SPANNING_HALL, domain, FIRST_BAND)
    e_band_shortfall(lm, bands)
    result = run_level(lm, time_limit=10)
    assert result.status is LevelStatus.OPTIMAL and result.rects is not None
    assert result.objective is not None
    for name, ((w_lo, d_lo), (w_hi, d_hi)) in bands.items():
        box = result.rects[name]
        if name == "hall":
            # Its shortfall is all there is: at least 4 m wide against at most 1.5 m.
            assert box.width >= 4 - 1e-6
            assert result.objective == pytest.approx(box.width - w_hi, abs=1e-4)
            continue
        assert w_lo - 1e-6 <= box.width <= w_hi + 1e-6, (name, box)
        assert d_lo - 1e-6 <= box.depth <= d_hi + 1e-6, (name, box)
