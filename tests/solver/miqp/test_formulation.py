"""The level MIQP one constraint family at a time (paper Sec. 5.1-5.3, Eq. 1-13).

Each test builds a tiny level (1-3 rectangles in a 6 x 4 box) with only the
families under test plus what they need, pins variables by tightening their
bounds or pushes them with a linear objective, and asserts the status or the
solved geometry. Where it helps, the same case without the family is the
control: the family must be what changes the answer.
"""

from __future__ import annotations

import pytest
from pyscipopt import Expr

from floorplan.solver.geometry import Box, Edge, boundary_edges
from floorplan.solver.miqp.formulation import (
    c_boundary,
    c_inside,
    c_overlap,
    c_pos,
    c_ratio,
    c_size,
)
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.scip_run import LevelStatus
from tests.solver.miqp.levels import (
    L_BLOCKED,
    L_EDGES,
    SOLVED,
    TOL,
    build,
    fix,
    fix_box,
    level,
    minimize,
    overlap_area,
    rect,
    solve,
    solved_rects,
)

CENTRE_BLOCK = Box(2, 1, 4, 3)


@pytest.mark.parametrize(
    "placed",
    [Box(4, 0, 7, 2), Box(0, 3, 2, 5), Box(4.5, 2.5, 6.5, 4.5)],
    ids=["east", "north", "north-east"],
)
def test_c_inside_keeps_the_rectangle_in_the_region(placed: Box) -> None:
    for families, expected in (((c_inside,), LevelStatus.INFEASIBLE), ((), LevelStatus.OPTIMAL)):
        lm = build(level(rect("a")), *families)
        fix_box(lm, "a", placed)
        assert solve(lm).status is expected


@pytest.mark.parametrize(
    ("placed", "feasible"),
    [
        (Box(2.5, 1.5, 3.5, 2.5), False),  # inside the blocked box
        (Box(1.5, 0.5, 2.5, 1.5), False),  # over its south-west corner
        (Box(1.5, 1.5, 2.5, 2.5), False),  # into its west side
        (Box(3.5, 1.5, 4.5, 2.5), False),  # into its east side
        (Box(2.5, 0.5, 3.5, 1.5), False),  # into its south side
        (Box(2.5, 2.5, 3.5, 3.5), False),  # into its north side
        (Box(0, 1.5, 6, 2.5), False),  # across it
        (Box(1, 1, 2, 2), True),  # touching its west side
        (Box(2, 3, 4, 4), True),  # touching its north side
        (Box(4, 0, 6, 4), True),  # touching its east side
    ],
)
def test_c_inside_keeps_blocked_boxes_clear(placed: Box, feasible: bool) -> None:
    spec = level(rect("a"), blocked=[CENTRE_BLOCK])
    lm = build(spec, c_inside)
    fix_box(lm, "a", placed)
    assert (solve(lm).status in SOLVED) is feasible
    lm = build(spec)
    fix_box(lm, "a", placed)
    assert solve(lm).status in SOLVED


def test_c_inside_full_depth_rectangle_grows_only_beside_a_blocked_box() -> None:
    lm = build(level(rect("a"), blocked=[CENTRE_BLOCK]), c_inside)
    fix(lm, "a", d=4)
    minimize(lm, -lm.rects["a"].w)
    (a,) = solved_rects(lm).values()
    assert a.width == pytest.approx(2, abs=TOL)
    assert overlap_area(a, CENTRE_BLOCK) == pytest.approx(0, abs=TOL)


CORE = Box(2, 1, 4, 3)


@pytest.mark.parametrize(
    ("other", "feasible"),
    [
        (Box(3, 2, 5, 3), False),  # overlapping
        (Box(1, 0.5, 3, 1.5), False),  # over a corner
        (Box(2.5, 1.5, 3.5, 2.5), False),  # nested
        (Box(0.5, 1, 2.5, 3), False),  # 0.5 m into the west side
        (Box(3.5, 1, 5.5, 3), False),  # 0.5 m into the east side
        (Box(2, 0, 4, 1.5), False),  # 0.5 m into the south side
        (Box(2, 2.5, 4, 4), False),  # 0.5 m into the north side
        (Box(0, 1, 2, 2), True),  # left, touching
        (Box(4, 2, 6, 3), True),  # right, touching
        (Box(1, 0, 3, 1), True),  # below, touching
        (Box(3, 3, 5, 4), True),  # above, touching
        (Box(5, 0, 6, 1), True),  # apart diagonally
    ],
)
def test_c_overlap_separates_a_pair(other: Box, feasible: bool) -> None:
    spec = level(rect("a"), rect("b"))
    lm = build(spec, c_inside, c_overlap)
    fix_box(lm, "a", CORE)
    fix_box(lm, "b", other)
    assert (solve(lm).status in SOLVED) is feasible


def test_c_overlap_forbids_stacked_squares_only_when_present() -> None:
    spec = level(rect("a"), rect("b"))
    for families, expected in (
        ((c_inside, c_overlap), LevelStatus.INFEASIBLE),
        ((c_inside,), LevelStatus.OPTIMAL),
    ):
        lm = build(spec, *families)
        fix_box(lm, "a", Box(0, 0, 3, 3))
        fix_box(lm, "b", Box(1, 1, 4, 4))
        assert solve(lm).status is expected


def test_c_overlap_keeps_two_growing_rectangles_apart() -> None:
    lm = build(level(rect("a"), rect("b")), c_inside, c_overlap)
    a, b = lm.rects["a"], lm.rects["b"]
    minimize(lm, -(a.w + a.d + b.w + b.d))
    boxes = solved_rects(lm)
    assert overlap_area(boxes["a"], boxes["b"]) == pytest.approx(0, abs=TOL)


@pytest.mark.parametrize("sense", [1, -1], ids=["smallest", "largest"])
def test_c_size_bounds_width_and_depth(sense: int) -> None:
    spec = level(rect("a", min_size=(2, 1), max_size=(3, 2)))
    expected = {1: (2, 1), -1: (3, 2)}[sense]
    unconstrained = {1: (0, 0), -1: (6, 4)}[sense]
    for families, (w, d) in (((c_inside, c_size), expected), ((c_inside,), unconstrained)):
        lm = build(spec, *families)
        v = lm.rects["a"]
        minimize(lm, sense * (v.w + v.d))
        (a,) = solved_rects(lm).values()
        assert (a.width, a.depth) == pytest.approx((w, d), abs=TOL)


@pytest.mark.parametrize("min_size", [(7, 1), (1, 5)], ids=["too-wide", "too-deep"])
def test_c_size_minimum_beyond_the_region_is_infeasible(min_size: tuple[float, float]) -> None:
    spec = level(rect("a", min_size=min_size))
    assert solve(build(spec, c_inside, c_size)).status is LevelStatus.INFEASIBLE
    assert solve(build(spec, c_inside)).status in SOLVED


@pytest.mark.parametrize("fixed_side", ["w", "d"])
@pytest.mark.parametrize("sense", [1, -1], ids=["min", "max"])
def test_c_ratio_bounds_the_other_side(fixed_side: str, sense: int) -> None:
    # Ratio [2, 3] with one side 4: the other lies in [4/3, 2] (4 * 2 = 8 does not fit).
    lm = build(level(rect("a", aspect_ratio=(2, 3))), c_inside, c_ratio)
    fix(lm, "a", **{fixed_side: 4.0})
    v = lm.rects["a"]
    other = v.d if fixed_side == "w" else v.w
    minimize(lm, sense * other)
    (a,) = solved_rects(lm).values()
    got = a.depth if fixed_side == "w" else a.width
    assert got == pytest.approx(4 / 3 if sense == 1 else 2, abs=TOL)


def test_c_ratio_without_the_family_the_other_side_is_free() -> None:
    lm = build(level(rect("a", aspect_ratio=(2, 3))), c_inside)
    fix(lm, "a", w=4)
    minimize(lm, -lm.rects["a"].d)
    (a,) = solved_rects(lm).values()
    assert a.depth == pytest.approx(4, abs=TOL)


@pytest.mark.parametrize("orientation", ["wide", "tall"])
def test_c_ratio_allows_either_orientation(orientation: str) -> None:
    lm = build(level(rect("a", aspect_ratio=(2, 3))), c_inside, c_ratio)
    if orientation == "wide":
        fix(lm, "a", w=3, d=1.25)
    else:
        fix(lm, "a", w=1.25, d=3)
    assert solve(lm).status in SOLVED


@pytest.mark.parametrize(("w", "d"), [(1.9, 1), (3, 0.9), (1, 3.1), (2, 1.9)])
def test_c_ratio_rejects_ratios_outside_the_range(w: float, d: float) -> None:
    lm = build(level(rect("a", aspect_ratio=(2, 3))), c_inside, c_ratio)
    fix(lm, "a", w=w, d=d)
    assert solve(lm).status is LevelStatus.INFEASIBLE


def test_c_ratio_one_forces_a_square() -> None:
    lm = build(level(rect("a", aspect_ratio=(1, 1))), c_inside, c_ratio)
    v = lm.rects["a"]
    minimize(lm, -(2 * v.w + v.d))  # would pick 6 x 4 if it could
    (a,) = solved_rects(lm).values()
    assert a.width == pytest.approx(4, abs=TOL)
    assert a.depth == pytest.approx(4, abs=TOL)


def covers(b: Box, point: tuple[float, float]) -> bool:
    px, py = point
    return b.x0 - TOL <= px <= b.x1 + TOL and b.y0 - TOL <= py <= b.y1 + TOL


@pytest.mark.parametrize(
    "points",
    [((4.5, 3.2),), ((1.2, 0.5), (1.8, 1.5)), ((0.0, 0.0),)],
    ids=["one", "two", "corner"],
)
@pytest.mark.parametrize("sense", [1, -1], ids=["pushed-south-west", "pushed-north-east"])
def test_c_pos_covers_the_guide_points(points: tuple[tuple[float, float], ...],
                                       sense: int) -> None:
    lm = build(level(rect("a", positions=points)), c_inside, c_pos)
    fix(lm, "a", w=1, d=1)
    v = lm.rects["a"]
    minimize(lm, sense * (v.x + v.y))
    (a,) = solved_rects(lm).values()
    assert all(covers(a, p) for p in points)
    # Pushed as far as it goes, a point sits on the rectangle's far side.
    if sense == 1:
        assert a.x1 == pytest.approx(max(1.0, max(px for px, _ in points)), abs=TOL)
    else:
        assert a.x0 == pytest.approx(min(5.0, min(px for px, _ in points)), abs=TOL)


def test_c_pos_points_too_far_apart_for_the_size_are_infeasible() -> None:
    spec = level(rect("a", positions=((0.5, 0.5), (3, 3))))
    for families, expected in (((c_inside, c_pos), LevelStatus.INFEASIBLE),
                               ((c_inside,), LevelStatus.OPTIMAL)):
        lm = build(spec, *families)
        fix(lm, "a", w=1, d=1)
        assert solve(lm).status is expected



# The 6 x 4 box with a vertex in the middle of every wall: each edge's span, not the
# region, is what stops the rectangle sliding along it.
SPLIT_EDGES = boundary_edges([(0, 0), (3, 0), (6, 0), (6, 2), (6, 4), (3, 4), (0, 4), (0, 2)])

EDGE_CASES = [(e, L_BLOCKED) for e in L_EDGES] + [(e, ()) for e in SPLIT_EDGES]

EDGE_IDS = [f"L{e.index}-{e.facing}" for e in L_EDGES] + [
    f"split{e.index}-{e.facing}" for e in SPLIT_EDGES
]


def test_test_rings_have_every_facing() -> None:
    assert [e.facing for e in L_EDGES] == ["south", "east", "north", "east", "north", "west"]
    assert [e.facing for e in SPLIT_EDGES] == ["south", "south", "east", "east",
                                               "north", "north", "west", "west"]


def side_on(b: Box, e: Edge) -> float:
    """The coordinate of the rectangle's side that faces like `e`."""
    return {"south": b.y0, "north": b.y1, "west": b.x0, "east": b.x1}[e.facing]


def along(b: Box, e: Edge) -> tuple[float, float]:
    return (b.x0, b.x1) if e.horizontal else (b.y0, b.y1)


def away_from(lm: LevelModel, e: Edge, slide: int) -> Expr:
    """Push the rectangle away from `e` (strongly) and along it (`slide` = +1: towards
    the low end)."""
    v = lm.rects["a"]
    across, run = (v.y, v.x) if e.horizontal else (v.x, v.y)
    outward = -1 if e.facing in ("south", "west") else 1
    return 10 * outward * across + slide * run


@pytest.mark.parametrize("slide", [1, -1], ids=["low-end", "high-end"])
@pytest.mark.parametrize(("edge", "blocked"), EDGE_CASES, ids=EDGE_IDS)
def test_c_boundary_puts_the_matching_side_on_the_edge(edge: Edge, blocked: tuple[Box, ...],
                                                       slide: int) -> None:
    lm = build(level(rect("a", edges=(edge,)), blocked=blocked), c_inside, c_boundary)
    fix(lm, "a", w=1, d=1)
    minimize(lm, away_from(lm, edge, slide))
    (a,) = solved_rects(lm).values()
    assert side_on(a, edge) == pytest.approx(edge.line, abs=TOL)
    lo, hi = edge.span
    start, end = along(a, edge)
    assert lo - TOL <= start and end <= hi + TOL
    # Slid as far as it goes, it stops at the edge's end, not the region's.
    assert (start if slide == 1 else end) == pytest.approx(lo if slide == 1 else hi, abs=TOL)


@pytest.mark.parametrize(("edge", "blocked"), EDGE_CASES, ids=EDGE_IDS)
def test_c_boundary_control_pushed_rectangle_leaves_the_edge(edge: Edge,
                                                             blocked: tuple[Box, ...]) -> None:
    lm = build(level(rect("a", edges=(edge,)), blocked=blocked), c_inside)
    fix(lm, "a", w=1, d=1)
    minimize(lm, away_from(lm, edge, 1))
    (a,) = solved_rects(lm).values()
    assert abs(side_on(a, edge) - edge.line) >= 1 - TOL


def test_c_boundary_candidate_edge_beyond_a_sub_region_does_not_bind() -> None:
    # A neighbourhood's region is a part of the domain; an unchosen candidate edge may
    # lie far outside it and must not cut the region down (its big-M spans the edge).
    _, east, north, _ = boundary_edges([(0, 0), (10, 0), (10, 4), (0, 4)])
    spec = level(rect("a", edges=(east, north)), region=Box(0, 0, 3, 4))
    lm = build(spec, c_inside, c_boundary)
    fix(lm, "a", w=1, d=1)
    minimize(lm, -lm.rects["a"].x)
    (a,) = solved_rects(lm).values()
    assert (a.x1, a.y1) == pytest.approx((3, 4), abs=TOL)


@pytest.mark.parametrize(
    ("y", "feasible"), [(0, True), (1.5, False), (3, True)], ids=["south", "middle", "north"]
)
def test_c_boundary_any_of_two_edges(y: float, feasible: bool) -> None:
    south, north = L_EDGES[0], L_EDGES[4]
    spec = level(rect("a", edges=(south, north)), blocked=L_BLOCKED)
    lm = build(spec, c_inside, c_boundary)
    fix(lm, "a", x=1, y=y, w=1, d=1)
    assert (solve(lm).status in SOLVED) is feasible
    lm = build(spec, c_inside)
    fix(lm, "a", x=1, y=y, w=1, d=1)
    assert solve(lm).status in SOLVED


@pytest.mark.parametrize("sense", [1, -1], ids=["pushed-south", "pushed-north"])
def test_c_boundary_any_of_two_edges_solved_holds_one(sense: int) -> None:
    east, north = L_EDGES[1], L_EDGES[4]  # x = 6 (y in [0, 2]) or y = 4 (x in [0, 4])
    lm = build(level(rect("a", edges=(east, north)), blocked=L_BLOCKED), c_inside, c_boundary)
    fix(lm, "a", w=1, d=1)
    v = lm.rects["a"]
    minimize(lm, 10 * sense * v.y - v.x)
    (a,) = solved_rects(lm).values()
    on_east = a.x1 == pytest.approx(6, abs=TOL) and a.y1 <= 2 + TOL
    on_north = a.y1 == pytest.approx(4, abs=TOL) and a.x1 <= 4 + TOL
    assert on_east or on_north
    assert (on_east, on_north) == ((True, False) if sense == 1 else (False, True))


# A U: the 6 x 4 box with a notch (2, 2)-(4, 4) cut from its top. The notch's sides are
# exterior walls facing each other across it, each with the other arm of the U beyond.
U_EDGES = boundary_edges([(0, 0), (6, 0), (6, 4), (4, 4), (4, 2), (2, 2), (2, 4), (0, 4)])
U_BLOCKED = (Box(2, 2, 4, 4),)


@pytest.mark.parametrize(("edge", "x", "feasible"), [
    (U_EDGES[3], 4.0, True), (U_EDGES[3], 0.5, False),
    (U_EDGES[5], 1.0, True), (U_EDGES[5], 4.5, False),
], ids=["west-wall-on", "west-wall-other-arm", "east-wall-on", "east-wall-other-arm"])
def test_c_boundary_holds_a_notch_wall_from_both_sides(edge: Edge, x: float,
                                                       feasible: bool) -> None:
    # A rectangle in the U's other arm lies on the wall's inner side of its line and
    # within its span, yet nowhere near it: C_inside does not rule it out there.
    assert (edge.facing, edge.line) in {("west", 4.0), ("east", 2.0)}
    spec = level(rect("a", edges=(edge,)), blocked=U_BLOCKED)
    lm = build(spec, c_inside, c_boundary)
    fix(lm, "a", x=x, y=2.5, w=1, d=1)
    assert (solve(lm).status in SOLVED) is feasible
