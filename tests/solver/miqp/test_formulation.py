"""The level MIQP one constraint family at a time (paper Sec. 5.1-5.3, Eq. 1-13).

Each test builds a tiny level (1-3 rectangles in a 6 x 4 box) with only the
families under test plus what they need, pins variables by tightening their
bounds or pushes them with a linear objective, and asserts the status or the
solved geometry. Where it helps, the same case without the family is the
control: the family must be what changes the answer.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from collections.abc import Sequence
from typing import Any

import pytest
import shapely
from pyscipopt import Expr

from solver.geometry import Box, Edge, boundary_edges
from solver.miqp.formulation import (
    FAMILIES,
    Family,
    build_level,
    c_adj,
    c_boundary,
    c_envelope,
    c_inside,
    c_overlap,
    c_pos,
    c_ratio,
    c_refine,
    c_size,
)
from solver.miqp.model import LevelModel
from solver.miqp.scip_run import LevelResult, LevelStatus, run_level
from solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec, Refine, Split

#: Every solve here is tiny; a generous cap that none should come near.
TIME_LIMIT = 5.0
#: Geometry read back from SCIP is exact to its feasibility tolerance (1e-6).
TOL = 1e-5
#: The objective's minimiser is compared to the analytic one at this tolerance.
ARGMIN_TOL = 1e-3

REGION = Box(0, 0, 6, 4)
SOLVED = (LevelStatus.OPTIMAL, LevelStatus.FEASIBLE)

# helpers


def level(
    *rects: RectSpec,
    region: Box = REGION,
    blocked: Sequence[Box] = (),
    contacts: Sequence[ContactSpec] = (),
    envelopes: Sequence[EnvelopeSpec] = (),
    cover_weight: float = 1.0,
    size_weight: float = 1.0,
) -> LevelSpec:
    """A level over `region` (free area: the region minus `blocked`)."""
    return LevelSpec(
        name="test",
        region=region,
        blocked=tuple(blocked),
        free_area=region.area - sum(b.area for b in blocked),
        rects=rects,
        contacts=tuple(contacts),
        envelopes=tuple(envelopes),
        cover_weight=cover_weight,
        size_weight=size_weight,
    )


def rect(name: str, room: str | None = None, **fields: Any) -> RectSpec:
    """A rectangle, by default its own room."""
    return RectSpec(name=name, room=room or name, **fields)


def build(spec: LevelSpec, *families: Family) -> LevelModel:
    """The model with only `families` and no objective (tests set their own)."""
    return build_level(spec, families=families, feasibility=True)


def fix(
    lm: LevelModel,
    name: str,
    *,
    x: float | None = None,
    y: float | None = None,
    w: float | None = None,
    d: float | None = None,
) -> None:
    """Pin some of a rectangle's variables by collapsing their bounds."""
    v = lm.rects[name]
    for var, value in ((v.x, x), (v.y, y), (v.w, w), (v.d, d)):
        if value is not None:
            lm.model.chgVarLb(var, value)
            lm.model.chgVarUb(var, value)


def fix_box(lm: LevelModel, name: str, b: Box) -> None:
    fix(lm, name, x=b.x0, y=b.y0, w=b.width, d=b.depth)


def minimize(lm: LevelModel, expr: Expr) -> None:
    """A linear objective that pushes the rectangles where the test wants them."""
    lm.model.setObjective(expr, "minimize")


def solve(lm: LevelModel) -> LevelResult:
    result = run_level(lm, time_limit=TIME_LIMIT)
    assert result.status is not LevelStatus.NO_SOLUTION, "a tiny model hit the time limit"
    return result


def solved_rects(lm: LevelModel) -> dict[str, Box]:
    result = solve(lm)
    assert result.status in SOLVED
    assert result.rects is not None
    return result.rects


def shared(a: Box, b: Box) -> float:
    """Length of wall two rectangles share; sides within TOL count as one line (solved
    coordinates are off by rounding, which an exact polygon intersection would miss)."""
    x_run = max(0.0, min(a.x1, b.x1) - max(a.x0, b.x0))
    y_run = max(0.0, min(a.y1, b.y1) - max(a.y0, b.y0))
    side_by_side = abs(a.x1 - b.x0) <= TOL or abs(b.x1 - a.x0) <= TOL
    stacked = abs(a.y1 - b.y0) <= TOL or abs(b.y1 - a.y0) <= TOL
    return max(y_run if side_by_side else 0.0, x_run if stacked else 0.0)


def overlap_area(a: Box, b: Box) -> float:
    return float(a.to_polygon().intersection(b.to_polygon()).area)


# C_inside (Eq. 1, and Eq. 2 against the blocked boxes)

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


# C_overlap (Eq. 2)

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


# C_size (Eq. 5)


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


# C_ratio (Eq. 7)


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


# C_pos (Eq. 8)


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


# C_boundary (Eq. 9, all four facings)

# An L: the 6 x 4 box without its north-east 2 x 2 corner.
L_RING = [(0, 0), (6, 0), (6, 2), (4, 2), (4, 4), (0, 4)]
L_EDGES = boundary_edges(L_RING)
L_BLOCKED = (Box(4, 2, 6, 4),)
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


# C_adj (Eq. 10, 11 and the minimum-length guard)


def test_c_adj_pushed_apart_rooms_still_share_the_contact_length() -> None:
    spec = level(rect("a"), rect("b"),
                 contacts=[ContactSpec("ab", ("a",), (("b",),), min_contact=1.5)])
    for families, expected in (((c_inside, c_overlap, c_adj), 1.5),
                               ((c_inside, c_overlap), 0.0)):
        lm = build(spec, *families)
        fix(lm, "a", w=2, d=2)
        fix(lm, "b", w=2, d=2)
        a, b = lm.rects["a"], lm.rects["b"]
        minimize(lm, 10 * (a.x - b.x) + (a.y - b.y))  # apart in x, then in y
        boxes = solved_rects(lm)
        assert shared(boxes["a"], boxes["b"]) == pytest.approx(expected, abs=TOL)
        assert overlap_area(boxes["a"], boxes["b"]) == pytest.approx(0, abs=TOL)


@pytest.mark.parametrize(
    ("a_at", "feasible"),
    [
        (Box(2, 2, 4, 3), True),  # on top, 2 m of wall
        (Box(3.5, 2, 5.5, 3), True),  # on top, offset: 1.5 m
        (Box(4, 2, 6, 3), False),  # on top, offset: 1 m
        (Box(5, 1, 6, 3), False),  # east, 1 m of wall
        (Box(5, 0.5, 6, 3), True),  # east, 1.5 m of wall
        (Box(5.5, 0, 6, 1), False),  # apart
    ],
)
def test_c_adj_fixed_pairs(a_at: Box, feasible: bool) -> None:
    spec = level(rect("a"), rect("b"),
                 contacts=[ContactSpec("ab", ("a",), (("b",),), min_contact=1.5)])
    lm = build(spec, c_inside, c_overlap, c_adj)
    fix_box(lm, "a", a_at)
    fix_box(lm, "b", Box(1, 0.5, 5, 2))
    assert (solve(lm).status in SOLVED) is feasible


@pytest.mark.parametrize(
    ("b_at", "c_at", "feasible"),
    [
        (Box(1, 0, 2, 1), Box(5, 3, 6, 4), True),  # touches b only
        (Box(5, 3, 6, 4), Box(0, 1, 1, 2), True),  # touches c only
        (Box(1, 0, 2, 1), Box(0, 1, 1, 2), True),  # touches both
        (Box(2, 0, 3, 1), Box(5, 3, 6, 4), False),  # touches neither
    ],
)
def test_c_adj_any_of_two_partners(b_at: Box, c_at: Box, feasible: bool) -> None:
    spec = level(rect("a"), rect("b"), rect("c"),
                 contacts=[ContactSpec("any", ("a",), (("b",), ("c",)), min_contact=1)])
    lm = build(spec, c_inside, c_overlap, c_adj)
    fix_box(lm, "a", Box(0, 0, 1, 1))
    fix_box(lm, "b", b_at)
    fix_box(lm, "c", c_at)
    assert (solve(lm).status in SOLVED) is feasible


@pytest.mark.parametrize("sense", [1, -1])
def test_c_adj_any_of_solved_touches_one_partner(sense: int) -> None:
    spec = level(rect("a"), rect("b"), rect("c"),
                 contacts=[ContactSpec("any", ("a",), (("b",), ("c",)), min_contact=1)])
    lm = build(spec, c_inside, c_overlap, c_adj)
    fix(lm, "a", w=1, d=1)
    fix_box(lm, "b", Box(0, 0, 1, 1))
    fix_box(lm, "c", Box(5, 3, 6, 4))
    v = lm.rects["a"]
    minimize(lm, sense * (v.x + v.y))
    boxes = solved_rects(lm)
    walls = (shared(boxes["a"], boxes["b"]), shared(boxes["a"], boxes["c"]))
    assert max(walls) == pytest.approx(1, abs=TOL)
    # Pushed towards one partner it touches that one.
    assert walls[0 if sense == 1 else 1] == pytest.approx(1, abs=TOL)


@pytest.mark.parametrize(("width", "feasible"), [(0.5, False), (1.0, True)])
def test_c_adj_narrow_room_nested_in_the_span_needs_the_full_length(width: float,
                                                                    feasible: bool) -> None:
    # a sits on b, inside b's span: Eq. 10 alone accepts 0.5 m of wall for c = 1.
    spec = level(rect("a"), rect("b"),
                 contacts=[ContactSpec("ab", ("a",), (("b",),), min_contact=1)])
    lm = build(spec, c_inside, c_overlap, c_adj)
    fix(lm, "a", x=2, y=1, w=width, d=1)
    fix_box(lm, "b", Box(0, 0, 5, 1))
    assert (solve(lm).status in SOLVED) is feasible


@pytest.mark.parametrize("order", ["narrow-first", "narrow-second"])
def test_c_adj_narrow_room_solved_shares_the_full_length(order: str) -> None:
    names = ("a", "b") if order == "narrow-first" else ("b", "a")
    spec = level(rect("a"), rect("b"),
                 contacts=[ContactSpec("ab", (names[0],), ((names[1],),), min_contact=1)])
    lm = build(spec, c_inside, c_overlap, c_adj)
    fix(lm, "a", w=0.5, d=2)  # too narrow for a horizontal 1 m wall
    fix(lm, "b", w=4, d=1)
    a, b = lm.rects["a"], lm.rects["b"]
    minimize(lm, b.y - a.y)  # a above b, if it could
    boxes = solved_rects(lm)
    assert shared(boxes["a"], boxes["b"]) >= 1 - TOL


@pytest.mark.parametrize(
    ("near", "feasible"),
    [(Box(3, 0, 5, 4), True), (Box(3.5, 0, 5, 4), False)],
    ids=["on-the-region-side", "off-it"],
)
def test_c_adj_fixed_partners_outside_the_region(near: Box, feasible: bool) -> None:
    # A neighbourhood holds partners fixed outside its region; the contact may pick the
    # near one while the far one's big-M still holds (M spans the fixed rectangles).
    spec = level(
        rect("a"),
        rect("near", fixed=near),
        rect("far", fixed=Box(10, 0, 12, 4)),
        region=Box(0, 0, 3, 4),
        contacts=[ContactSpec("any", ("a",), (("near",), ("far",)), min_contact=2)],
    )
    lm = build(spec, c_inside, c_overlap, c_size, c_adj)
    minimize(lm, lm.rects["a"].x)
    result = solve(lm)
    assert (result.status in SOLVED) is feasible
    if feasible:
        assert result.rects is not None
        assert result.rects["near"] == near
        assert shared(result.rects["a"], near) >= 2 - TOL


# C_refine (Eq. 13 and its horizontal twin)

PARENT = Box(1, 1, 5, 3)
DELTA = 0.5

# Reachable range of each side (x0, y0, x1, y1) of a half of PARENT, in REGION.
# The split-side of a half is not bounded by C_refine (its sibling bounds it).
REFINE_RANGES: dict[tuple[Split, int], dict[str, tuple[float, float]]] = {
    ("vertical", 0): {"x0": (0.5, 1), "y0": (0.5, 1), "x1": (0.5, 6), "y1": (3, 3.5)},
    ("vertical", 1): {"x0": (0, 5.5), "y0": (0.5, 1), "x1": (5, 5.5), "y1": (3, 3.5)},
    ("horizontal", 0): {"x0": (0.5, 1), "y0": (0.5, 1), "x1": (5, 5.5), "y1": (0.5, 4)},
    ("horizontal", 1): {"x0": (0.5, 1), "y0": (0, 3.5), "x1": (5, 5.5), "y1": (3, 3.5)},
    ("vertical", -1): {"x0": (0.5, 1), "y0": (0.5, 1), "x1": (5, 5.5), "y1": (3, 3.5)},
    ("horizontal", -1): {"x0": (0.5, 1), "y0": (0.5, 1), "x1": (5, 5.5), "y1": (3, 3.5)},
}


def side_expr(lm: LevelModel, side: str) -> Expr:
    v = lm.rects["a"]
    return {"x0": v.x + 0, "y0": v.y + 0, "x1": v.x + v.w, "y1": v.y + v.d}[side]


@pytest.mark.parametrize(("direction", "child"), list(REFINE_RANGES))
def test_c_refine_each_side_moves_within_its_range(direction: Split, child: int) -> None:
    spec = level(rect("a", refine=Refine(PARENT, direction, child, DELTA)))
    for side, (lo, hi) in REFINE_RANGES[direction, child].items():
        for sense, expected in ((1, lo), (-1, hi)):
            lm = build(spec, c_inside, c_refine)
            minimize(lm, sense * side_expr(lm, side))
            (a,) = solved_rects(lm).values()
            got = {"x0": a.x0, "y0": a.y0, "x1": a.x1, "y1": a.y1}[side]
            assert got == pytest.approx(expected, abs=TOL), (side, sense)


@pytest.mark.parametrize(("direction", "child"), list(REFINE_RANGES))
def test_c_refine_half_cannot_shrink_below_the_parents_side(direction: Split,
                                                            child: int) -> None:
    spec = level(rect("a", refine=Refine(PARENT, direction, child, DELTA)))
    cross = "d" if direction == "vertical" else "w"
    side = PARENT.depth if direction == "vertical" else PARENT.width
    for length, feasible in ((side - 0.1, False), (side, True), (side + DELTA, True)):
        lm = build(spec, c_inside, c_refine)
        fix(lm, "a", **{cross: length})
        assert (solve(lm).status in SOLVED) is feasible, length


@pytest.mark.parametrize("direction", ["vertical", "horizontal"])
def test_c_refine_two_halves_cover_the_parent(direction: Split) -> None:
    # As the hierarchy builds them: two halves kept apart and sharing the split line.
    side = PARENT.depth if direction == "vertical" else PARENT.width
    spec = level(
        rect("h0", room="r", refine=Refine(PARENT, direction, 0, DELTA)),
        rect("h1", room="r", refine=Refine(PARENT, direction, 1, DELTA)),
        contacts=[ContactSpec("halves", ("h0",), (("h1",),), min_contact=side * 0.999)],
    )
    lm = build(spec, c_inside, c_overlap, c_adj, c_refine)
    h0, h1 = lm.rects["h0"], lm.rects["h1"]
    minimize(lm, h0.w + h0.d + h1.w + h1.d)  # as small as allowed
    boxes = solved_rects(lm)
    union = shapely.union_all([b.to_polygon() for b in boxes.values()])
    assert PARENT.to_polygon().difference(union).area == pytest.approx(0, abs=TOL)
    grown = Box(PARENT.x0 - DELTA, PARENT.y0 - DELTA, PARENT.x1 + DELTA, PARENT.y1 + DELTA)
    assert union.difference(grown.to_polygon()).area == pytest.approx(0, abs=TOL)
    low, high = (boxes["h0"], boxes["h1"])
    assert (low.x1 <= high.x0 + TOL) if direction == "vertical" else (low.y1 <= high.y0 + TOL)


# C_envelope (Eq. 5 and 7 on a room's bounding box)

PREVIOUS = Box(1, 1, 4, 3)  # 3 x 2, wide


def envelope_level(max_size: tuple[float, float],
                   aspect_ratio: tuple[float, float] | None) -> LevelSpec:
    return level(
        rect("a", room="r"),
        rect("b", room="r"),
        envelopes=[EnvelopeSpec("r", ("a", "b"), PREVIOUS, max_size, aspect_ratio)],
    )


@pytest.mark.parametrize(
    ("b_at", "feasible"),
    [
        (Box(2.5, 1, 4, 3), True),  # bounding box 3 x 2
        (Box(2.5, 1, 5, 3), True),  # 4 x 2
        (Box(2.5, 1, 5.1, 3), False),  # 4.1 x 2
        (Box(2.5, 1, 4, 4), True),  # 3 x 3
        (Box(2.5, 0.5, 4, 4), False),  # 3 x 3.5
    ],
)
def test_c_envelope_bounds_the_rooms_bounding_box(b_at: Box, feasible: bool) -> None:
    spec = envelope_level(max_size=(4, 3), aspect_ratio=None)
    for families, expected in (((c_inside, c_overlap, c_envelope), feasible),
                               ((c_inside, c_overlap), True)):
        lm = build(spec, *families)
        fix_box(lm, "a", Box(1, 1, 2.5, 3))
        fix_box(lm, "b", b_at)
        assert (solve(lm).status in SOLVED) is expected


PREVIOUS_TALL = Box(1, 0, 3, 3)  # 2 x 3, tall


@pytest.mark.parametrize(
    ("previous", "a_at", "b_at", "feasible"),
    [
        (PREVIOUS, Box(1, 1, 2.5, 3), Box(2.5, 1, 4, 3), True),  # 3 x 2: ratio 1.5
        (PREVIOUS, Box(1, 1, 2.5, 3), Box(2.5, 1, 5, 3), True),  # 4 x 2: ratio 2
        (PREVIOUS, Box(1, 1, 2.5, 3), Box(2.5, 1, 5.5, 3), False),  # 4.5 x 2: ratio 2.25
        (PREVIOUS, Box(1, 1, 2.5, 3), Box(2.5, 1, 4, 3.5), False),  # 3 x 2.5: ratio 1.2
        (PREVIOUS_TALL, Box(1, 0, 3, 1.5), Box(1, 1.5, 3, 3), True),  # 2 x 3: ratio 1.5
        (PREVIOUS_TALL, Box(1, 0, 3, 1.5), Box(1, 1.5, 3, 4), True),  # 2 x 4: ratio 2
        (PREVIOUS_TALL, Box(1, 0, 3, 1.5), Box(1, 1.5, 3.5, 3), False),  # 2.5 x 3: ratio 1.2
    ],
)
def test_c_envelope_bounds_the_rooms_ratio(previous: Box, a_at: Box, b_at: Box,
                                           feasible: bool) -> None:
    # Only layouts whose bounding box breaks [1.5, 2] in either orientation are asserted
    # infeasible: the envelope's ratio bound is conservative by design.
    spec = level(
        rect("a", room="r"),
        rect("b", room="r"),
        envelopes=[EnvelopeSpec("r", ("a", "b"), previous, (6, 4), (1.5, 2))],
    )
    lm = build(spec, c_inside, c_overlap, c_envelope)
    fix_box(lm, "a", a_at)
    fix_box(lm, "b", b_at)
    assert (solve(lm).status in SOLVED) is feasible


def test_c_envelope_solved_room_stays_within_max_size() -> None:
    spec = envelope_level(max_size=(4, 3), aspect_ratio=None)
    lm = build(spec, c_inside, c_overlap, c_envelope)
    a, b = lm.rects["a"], lm.rects["b"]
    for v in (a, b):  # both keep covering PREVIOUS's span in y
        lm.model.chgVarUb(v.y, PREVIOUS.y0)
        lm.model.addCons(v.y + v.d >= PREVIOUS.y1, name=f"test_cover[{v.y.name}]")
    minimize(lm, -(a.w + a.d + b.w + b.d))
    boxes = solved_rects(lm)
    x0, y0, x1, y1 = shapely.union_all([r.to_polygon() for r in boxes.values()]).bounds
    assert x1 - x0 <= 4 + TOL
    assert y1 - y0 <= 3 + TOL


# E_cover + E_size (Eq. 3, 6, 12)


def energy(w: float, d: float, target: tuple[float, float], ls: float, lc: float) -> float:
    return ls * ((w - target[0]) ** 2 + (d - target[1]) ** 2) - lc * w * d


def argmin_energy(
    target: tuple[float, float],
    w_range: tuple[float, float],
    d_range: tuple[float, float],
    ls: float,
    lc: float,
) -> tuple[float, float]:
    """Minimiser of `energy` over a box (convex: ls >= lc / 2): the stationary point if
    inside, else the best of the four sides' clipped 1-D minimisers."""

    def clip(value: float, bounds: tuple[float, float]) -> float:
        return min(max(value, bounds[0]), bounds[1])

    tw, td = target
    candidates: list[tuple[float, float]] = []
    det = 4 * ls * ls - lc * lc
    if det > 1e-12:
        # 2 ls (w - tw) = lc d and 2 ls (d - td) = lc w
        w = (4 * ls * ls * tw + 2 * ls * lc * td) / det
        d = (4 * ls * ls * td + 2 * ls * lc * tw) / det
        if clip(w, w_range) == w and clip(d, d_range) == d:
            return (w, d)
    for w in w_range:  # a side w = const: d = td + lc w / (2 ls)
        candidates.append((w, clip(td + lc * w / (2 * ls), d_range)))
    for d in d_range:
        candidates.append((clip(tw + lc * d / (2 * ls), w_range), d))
    return min(candidates, key=lambda p: energy(*p, target, ls, lc))


@pytest.mark.parametrize(
    ("target", "min_size", "max_size", "ls", "lc"),
    [
        ((2, 1), (0, 0), (math.inf, math.inf), 1, 1),  # interior: (10/3, 8/3)
        ((2, 1), (0, 0), (3, math.inf), 1, 1),  # width clipped at its max
        ((1, 1), (2.5, 0), (math.inf, math.inf), 1, 1),  # width clipped at its min
        ((5, 3), (0, 0), (math.inf, math.inf), 1, 1),  # clipped to the region
        ((2, 1), (0, 0), (math.inf, math.inf), 3, 1),  # size dominates
        ((2, 1), (0, 0), (math.inf, math.inf), 0.5, 1),  # lambda_size = lambda_cover / 2
    ],
)
def test_e_objective_optimum_is_the_analytic_minimiser(
    target: tuple[float, float],
    min_size: tuple[float, float],
    max_size: tuple[float, float],
    ls: float,
    lc: float,
) -> None:
    spec = level(rect("a", target=target, min_size=min_size, max_size=max_size),
                 size_weight=ls, cover_weight=lc)
    lm = build_level(spec, families=[c_inside, c_size])
    result = solve(lm)
    assert result.status is LevelStatus.OPTIMAL
    assert result.rects is not None
    w_range = (min_size[0], min(max_size[0], REGION.width))
    d_range = (min_size[1], min(max_size[1], REGION.depth))
    w, d = argmin_energy(target, w_range, d_range, ls, lc)
    a = result.rects["a"]
    assert (a.width, a.depth) == pytest.approx((w, d), abs=ARGMIN_TOL)
    assert result.objective == pytest.approx(
        energy(w, d, target, ls, lc) + lc * spec.free_area, abs=ARGMIN_TOL
    )


@pytest.mark.parametrize("ls", [0.5, 1.0, 4.0])
def test_e_objective_is_convex_when_size_weight_is_half_cover_weight(ls: float) -> None:
    # Three rooms with targets in the full level: a convex MIQP solves to optimality fast.
    spec = level(
        rect("a", target=(3, 2)), rect("b", target=(2, 2)), rect("c", target=(1, 3)),
        contacts=[ContactSpec("ab", ("a",), (("b",),), min_contact=1)],
        size_weight=ls, cover_weight=1.0,
    )
    result = run_level(build_level(spec), time_limit=TIME_LIMIT)
    assert result.status is LevelStatus.OPTIMAL
    assert result.seconds < TIME_LIMIT / 2


# Every family at once: names


def full_spec() -> LevelSpec:
    edges = L_EDGES
    return level(
        rect("h0", room="r", target=(2, 2), refine=Refine(Box(0, 0, 4, 2), "vertical", 0, 0.5),
             edges=(edges[0], edges[5])),
        rect("h1", room="r", target=(2, 2), refine=Refine(Box(0, 0, 4, 2), "vertical", 1, 0.5),
             edges=(edges[0],)),
        rect("k", min_size=(1, 1), max_size=(3, 2), aspect_ratio=(1, 2),
             positions=((1, 3), (2, 3.5)), edges=(edges[4], edges[5])),
        rect("s", aspect_ratio=(1, 3), positions=((5, 1),)),
        rect("f", fixed=L_BLOCKED[0]),  # a settled neighbour, also blocked
        blocked=L_BLOCKED,
        contacts=[
            ContactSpec("halves", ("h0",), (("h1",),), min_contact=1.9),
            ContactSpec("k-any", ("k",), (("h0", "h1"), ("s",)), min_contact=1),
            ContactSpec("s-r", ("s",), (("h0", "h1"),), min_contact=1),
            ContactSpec("s-f", ("s",), (("f",),), min_contact=1),
        ],
        envelopes=[EnvelopeSpec("r", ("h0", "h1"), Box(0, 0, 4, 2), (5, 3), (1, 3))],
    )


def duplicates(names: Sequence[str]) -> list[str]:
    return sorted(n for n, k in Counter(names).items() if k > 1)


def test_every_family_builds_with_unique_names() -> None:
    lm = build_level(full_spec())
    assert lm.families == [f.__name__ for f in FAMILIES]
    assert duplicates([c.name for c in lm.model.getConss()]) == []
    assert duplicates([v.name for v in lm.model.getVars()]) == []


def test_every_family_level_is_solvable() -> None:
    result = run_level(build_level(full_spec()), time_limit=TIME_LIMIT)
    assert result.status in SOLVED
    assert result.rects is not None
    assert result.rects["f"] == L_BLOCKED[0]
    for a, b in itertools.combinations(result.rects.values(), 2):
        assert overlap_area(a, b) == pytest.approx(0, abs=TOL)
