"""The families between rectangles (paper Sec. 5): C_adj (Eq. 10-11), C_refine (Eq. 13)
and C_envelope (Eq. 5 and 7 on a room's bounding box), each on a tiny level with a
control case."""

from __future__ import annotations

import pytest
import shapely
from pyscipopt import Expr

from floorplan.solver.geometry import Box
from floorplan.solver.miqp.formulation import (
    c_adj,
    c_envelope,
    c_inside,
    c_overlap,
    c_refine,
    c_size,
)
from floorplan.solver.miqp.model import LevelModel
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, Refine, Split
from tests.solver.miqp.levels import (
    SOLVED,
    TOL,
    build,
    fix,
    fix_box,
    level,
    minimize,
    overlap_area,
    rect,
    shared,
    solve,
    solved_rects,
)


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
