"""Distinct plans and adjacency graphs (solver.distinct)."""

from __future__ import annotations

from floorplan.models import Layout, Report, RoomLayout
from floorplan.models.layout import Rect
from floorplan.solver.distinct import DistinctPlans, adjacency_graph, count_distinct


def _room(room_id: str, x: float, y: float, w: float, d: float) -> RoomLayout:
    return RoomLayout(id=room_id, type="room",
                      polygon=[(x, y), (x + w, y), (x + w, y + d), (x, y + d)],
                      rectangles=[Rect(x=x, y=y, width=w, depth=d)], area=w * d)


def _plan(split: float, *, kitchen_left: bool = False) -> Layout:
    """A 10 x 4 floor, living and kitchen side by side, split at `split`."""
    a, b = ("kitchen", "living") if kitchen_left else ("living", "kitchen")
    return Layout(rooms=[_room(a, 0, 0, split, 4), _room(b, split, 0, 10 - split, 4)],
                  report=Report(coverage=1.0, uncovered_area=0.0))


def test_a_small_shift_is_the_same_plan_a_swap_is_not() -> None:
    counter = DistinctPlans()
    assert counter.add(_plan(5.0))
    assert not counter.add(_plan(5.0))
    assert not counter.add(_plan(5.3))  # 3 % of the floor changed room
    assert counter.add(_plan(6.0))      # 10 %
    assert counter.add(_plan(5.0, kitchen_left=True))
    assert (counter.plans, counter.layouts) == (3, 5)


def test_adjacency_graphs() -> None:
    assert adjacency_graph(_plan(5.0)) == {("kitchen", "living")}
    apart = Layout(rooms=[_room("a", 0, 0, 2, 2), _room("b", 5, 0, 2, 2)],
                   report=Report(coverage=1.0, uncovered_area=0.0))
    assert adjacency_graph(apart) == frozenset()
    assert count_distinct([_plan(5.0), _plan(6.0), apart]) == (3, 2)
