"""Design variants as local re-layouts, on the real SCIP: a further variant of a single
floor lays out again only the rooms around one demanded wall, the others stay exactly
where the first layout has them, and the job's time bound says so.

Nothing asserts on wall time."""

from __future__ import annotations

import json
import time

from shapely.geometry import Polygon

from floorplan.models import Layout, Problem, Termination
from floorplan.solver.pipeline.variants import (
    LOCAL_ROOMS,
    LOCAL_TIME_FACTOR,
    VARIANT_TIME_FACTOR,
    free_rooms,
    local_variant,
    missing_walls,
    topology,
    variant_time_factor,
)
from tests.paths import EXAMPLES

HOUSE = Problem.model_validate_json((EXAMPLES / "house-13.json").read_text())
#: The committed answer to house-13: the first layout the variants start from.
FIRST = Layout.model_validate(json.loads((EXAMPLES / "house-13.layout.json").read_text()))
#: A fixed room must come back to this (m² of symmetric difference).
EXACT = 1e-4


def test_a_local_variant_makes_the_pair_touch_and_keeps_the_other_rooms() -> None:
    one = HOUSE.with_options(time_limit=10)
    missing = missing_walls(HOUSE, FIRST)
    assert missing, "the committed house-13 has no near pair that does not touch"
    for pair in missing[:3]:
        free = free_rooms(FIRST, pair)
        assert free[:2] == list(pair) and len(free) <= LOCAL_ROOMS
        variant = local_variant(one, FIRST, free, pair, seed=1,
                                deadline=time.monotonic() + 60)
        if variant is None:
            continue  # this wall cannot be had around its neighbours: the next
        assert variant.report.valid, variant.report
        assert variant.report.termination is Termination.STALLED
        assert variant.report.bound is None
        assert pair in topology(variant)
        before = {r.id: Polygon(r.polygon) for r in FIRST.rooms}
        for room in variant.rooms:
            if room.id not in free:
                assert Polygon(room.polygon).symmetric_difference(
                    before[room.id]).area < EXACT, room.id
        return
    raise AssertionError(f"none of {missing[:3]} could be made to touch")


def test_the_job_bound_is_twice_a_layout_on_one_floor_and_three_times_for_buildings() -> None:
    assert variant_time_factor(HOUSE) == 1
    assert variant_time_factor(HOUSE.with_options(variants=4)) == LOCAL_TIME_FACTOR == 2
    building = Problem.model_validate_json((EXAMPLES / "two-storey-house.json").read_text())
    assert variant_time_factor(building.with_options(variants=4)) == VARIANT_TIME_FACTOR


def test_the_service_bounds_a_job_with_variants_by_twice_its_limit() -> None:
    from floorplan.service.timing import effective_time_limit

    problem = HOUSE.with_options(variants=4, time_limit=10)
    asked, job_limit = effective_time_limit(problem, 100)
    assert (asked.options.time_limit, job_limit) == (10, 20)
    # Under a lower ceiling one layout's limit is cut so that the job stays under it.
    asked, job_limit = effective_time_limit(problem, 12)
    assert (asked.options.time_limit, job_limit) == (6, 12)
