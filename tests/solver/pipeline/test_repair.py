"""Gaps laid out afresh (solver/pipeline/repair.py): the rooms around a gap are freed
and laid out again around the others, held where they are."""

from __future__ import annotations

import time

from floorplan.models import Problem
from floorplan.solver.geometry import Box, make_domain
from floorplan.solver.pipeline.hierarchy import as_pieces, room_boxes
from floorplan.solver.pipeline.repair import repaired
from floorplan.solver.pipeline.run import Run, covers
from floorplan.solver.verify.checker import check_layout


def _three_rooms() -> Problem:
    return Problem.model_validate({
        "name": "repair", "boundary": [[0, 0], [6, 0], [6, 4], [0, 4]],
        "rooms": [
            {"id": "a", "min_size": [2, 2], "max_size": [3, 4], "target_size": [3, 4]},
            {"id": "b", "min_size": [1, 1], "max_size": [3, 2.5], "target_size": [3, 2]},
            {"id": "c", "min_size": [1, 1], "max_size": [3, 2.5], "target_size": [3, 2]},
        ],
        "adjacency": [{"a": "a", "b": "b"}, {"a": "b", "b": "c"}],
        "options": {"require_connected": False},
    })


def _run(problem: Problem, seconds: float) -> Run:
    now = time.monotonic()
    return Run(problem, now + seconds, now, None, None, end=now + seconds)


def test_the_rooms_around_a_gap_are_laid_out_afresh_and_the_rest_held() -> None:
    problem = _three_rooms()
    domain = make_domain(problem)
    # c is half as wide as it may be: a gap of 1.5 x 2 m beside it, above b.
    rooms = {"a": [Box(0, 0, 3, 4)], "b": [Box(3, 0, 6, 2)], "c": [Box(3, 2, 4.5, 4)]}
    assert not covers(domain, rooms)  # 87.5 % covered
    fixed = repaired(_run(problem, 3.0), domain, as_pieces(rooms))
    after = room_boxes(fixed)
    assert covers(domain, after)
    assert check_layout(problem, after).valid
    assert after["a"] == rooms["a"]  # not beside the gap: held


def test_a_covering_layout_is_left_as_it_is() -> None:
    problem = _three_rooms()
    rooms = {"a": [Box(0, 0, 3, 4)], "b": [Box(3, 0, 6, 2)], "c": [Box(3, 2, 6, 4)]}
    pieces = as_pieces(rooms)
    assert repaired(_run(problem, 3.0), make_domain(problem), pieces) is pieces
