"""The residential template (paper Sec. 5.4): expansion rules, then a templated flat
solved for real."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from floorplan.models import Problem
from floorplan.models.templates import KNOWN_TYPES, RESIDENTIAL, TemplatedProblem, expand
from floorplan.solver import solve
from floorplan.solver.geometry import make_domain
from floorplan.solver.verify.precheck import find_impossibilities
from tests.paths import EXAMPLES

FLAT: list[str] = ["living", "kitchen", "bedroom", "bedroom", "bathroom"]


def templated(rooms: list[Any], width: float = 10.0, depth: float = 8.0,
              **extra: Any) -> dict[str, Any]:
    return {"boundary": [[0, 0], [width, 0], [width, depth], [0, depth]],
            "template": "residential", "rooms": rooms, **extra}


def rooms_by_id(problem: Problem) -> dict[str, Any]:
    return {room.id: room for room in problem.rooms}


def contacts(problem: Problem) -> set[frozenset[str]]:
    """Every pair an adjacency asks to touch; `any_of` pairs the room with each option."""
    return {frozenset((adj.a, p)) for adj in problem.adjacency for p in adj.partners}


def error_locs(err: pytest.ExceptionInfo[ValidationError]) -> list[tuple[str | int, ...]]:
    return [tuple(e["loc"]) for e in err.value.errors()]


# Ids and types.


def test_bare_types_become_rooms_named_after_their_type_and_numbered_when_repeated() -> None:
    problem = Problem.model_validate(templated(FLAT))
    assert [(r.id, r.type) for r in problem.rooms] == [
        ("living", "living"), ("kitchen", "kitchen"), ("bedroom-1", "bedroom"),
        ("bedroom-2", "bedroom"), ("bathroom", "bathroom")]


def test_room_objects_keep_their_ids_and_generated_ids_avoid_them() -> None:
    problem = Problem.model_validate(templated(
        [{"id": "bedroom-1", "type": "bedroom"}, "bedroom", "bedroom", {"type": "Kitchen"}]))
    assert [(r.id, r.type) for r in problem.rooms] == [
        ("bedroom-1", "bedroom"), ("bedroom-2", "bedroom"), ("bedroom-3", "bedroom"),
        ("kitchen", "kitchen")]


def test_generated_ids_stay_within_the_id_length_limit() -> None:
    long_type = "x" * 100
    problem = Problem.model_validate(templated([{"type": long_type}] * 2, 20, 20))
    assert [r.id for r in problem.rooms] == ["x" * 90 + "-1", "x" * 90 + "-2"]


def test_the_expanded_problem_has_no_template_and_validates_to_itself() -> None:
    problem = Problem.model_validate(templated(FLAT, entrance=[2, 0]))
    assert "template" not in problem.model_dump()
    again = Problem.model_validate_json(problem.model_dump_json(exclude_unset=True))
    assert again == problem


def test_template_null_is_a_plain_problem() -> None:
    plain = {"boundary": [[0, 0], [4, 0], [4, 4], [0, 4]], "rooms": [{"id": "a"}]}
    assert Problem.model_validate({**plain, "template": None}) == Problem.model_validate(plain)


# Sizes.


def test_every_room_gets_sizes_a_ratio_and_the_targets_fill_the_free_area() -> None:
    problem = Problem.model_validate(templated(FLAT))
    for room in problem.rooms:
        assert room.min_size and room.max_size and room.target_size and room.aspect_ratio
        for axis in (0, 1):
            assert room.min_size[axis] <= room.target_size[axis] <= room.max_size[axis]
    target_area = sum(r.target_size[0] * r.target_size[1] for r in problem.rooms
                      if r.target_size)
    assert target_area == pytest.approx(80.0, rel=0.02)
    sizes = rooms_by_id(problem)
    assert sizes["living"].target_size[0] > sizes["bedroom-1"].target_size[0] > sizes[
        "bathroom"].target_size[0]


def test_sizes_scale_with_the_square_root_of_the_area() -> None:
    small = rooms_by_id(Problem.model_validate(templated(FLAT, 10, 8)))
    large = rooms_by_id(Problem.model_validate(templated(FLAT, 20, 16)))  # 4 x the area
    for room_id, room in small.items():
        big = large[room_id]
        for field in ("min_size", "max_size", "target_size"):
            for here, there in zip(getattr(room, field), getattr(big, field), strict=True):
                # Twice the lengths; a minimum held at its type's floor grows less.
                limit = 2 * here if field != "min_size" else max(
                    2 * here, RESIDENTIAL.sizes[room.type].floor)
                assert there == pytest.approx(limit, abs=0.011) or (
                    field == "min_size" and there <= limit), (room_id, field)


def test_a_minimum_never_drops_below_its_types_floor() -> None:
    crowded = Problem.model_validate(templated(["bedroom"] * 6 + ["bathroom"], 10, 7))
    for room in crowded.rooms:
        assert min(room.min_size) >= RESIDENTIAL.sizes[room.type].floor


def test_a_corridor_runs_along_the_longer_axis_of_the_outline() -> None:
    wide = rooms_by_id(Problem.model_validate(templated(["corridor", *FLAT], 14, 7)))
    tall = rooms_by_id(Problem.model_validate(templated(["corridor", *FLAT], 7, 14)))
    assert wide["corridor"].target_size[0] > wide["corridor"].target_size[1]
    assert tall["corridor"].target_size[1] > tall["corridor"].target_size[0]
    assert wide["corridor"].aspect_ratio[0] > 1


def test_what_the_user_states_wins_and_the_rest_agrees_with_it() -> None:
    problem = Problem.model_validate(templated([
        {"type": "living", "target_size": [9.5, 3.0], "boundary": ["south"]},
        {"type": "bedroom", "min_size": [3, 3], "aspect_ratio": [1, 3]},
        {"type": "bathroom", "boundary": []},
        "kitchen",
    ]))
    rooms = rooms_by_id(problem)
    living, bedroom, bathroom = rooms["living"], rooms["bedroom"], rooms["bathroom"]
    assert living.target_size == (9.5, 3.0) and living.boundary == ["south"]
    # Widened to admit the stated target: its bounds and ratio allow 9.5 x 3.
    assert living.max_size[0] >= 9.5 and living.min_size[1] <= 3.0
    assert living.aspect_ratio[1] >= 9.5 / 3.0
    assert bedroom.min_size == (3, 3) and bedroom.aspect_ratio == (1, 3)
    assert bedroom.target_size[0] >= 3 and bedroom.max_size[0] >= 3
    assert bathroom.boundary == []


def test_a_user_target_keeps_its_area_and_the_other_rooms_share_the_rest() -> None:
    problem = Problem.model_validate(templated(
        [{"type": "living", "target_size": [6, 5]}, "bedroom", "bathroom"]))
    others = sum(r.target_size[0] * r.target_size[1] for r in problem.rooms
                 if r.id != "living")
    assert others == pytest.approx(80 - 30, rel=0.02)


# Adjacency, exterior walls, the front door.


def test_default_adjacencies_pair_kitchen_and_dining_and_bedrooms_with_their_bathrooms() -> None:
    problem = Problem.model_validate(templated(
        ["foyer", "living", "kitchen", "dining", "bedroom", "bathroom", "bedroom", "bathroom"],
        12, 9))
    pairs = contacts(problem)
    assert frozenset(("kitchen", "dining")) in pairs
    assert frozenset(("bedroom-1", "bathroom-1")) in pairs
    assert frozenset(("bedroom-2", "bathroom-2")) in pairs


def test_with_fewer_bathrooms_than_bedrooms_the_bathroom_is_shared_off_the_foyer() -> None:
    problem = Problem.model_validate(templated(["foyer", *FLAT]))
    bath = [adj for adj in problem.adjacency if adj.a == "bathroom"]
    assert [adj.partners for adj in bath] == [["foyer"]]
    assert not any("bathroom" in pair and "bedroom-1" in pair for pair in contacts(problem))


def test_every_room_is_reachable_from_the_foyer_through_allowed_doors() -> None:
    problem = Problem.model_validate(templated(
        ["foyer", "corridor", "living", "kitchen", "bedroom", "bedroom", "bathroom", "wc",
         "storage"], 14, 9))
    graph = {r.id: set[str]() for r in problem.rooms}
    for adj in problem.adjacency:
        for partner in adj.partners:
            graph[adj.a].add(partner)
            graph[partner].add(adj.a)
    ends = set(problem.openings.no_passage)
    types = {r.id: r.type for r in problem.rooms}
    seen, todo = {"foyer"}, ["foyer"]
    while todo:
        here = todo.pop()
        if types[here] in ends:
            continue
        for there in graph[here] - seen:
            seen.add(there)
            todo.append(there)
    assert seen == set(graph)
    # A bathroom only ever opens where the door policy allows.
    allowed = problem.openings.door_policy["bathroom"]
    for adj in problem.adjacency:
        if types[adj.a] == "bathroom":
            assert all(types[p] in allowed for p in adj.partners)


def test_without_a_foyer_the_living_room_is_the_way_in_and_a_bathroom_opens_off_a_bedroom(
) -> None:
    problem = Problem.model_validate(templated(FLAT, entrance=[5, 0]))
    rooms = rooms_by_id(problem)
    assert rooms["living"].positions == [(5.0, 0.3)]
    bath = next(adj for adj in problem.adjacency if "bathroom" in (adj.a, *adj.partners))
    assert set(bath.partners) | {bath.a} <= {"bathroom", "bedroom-1", "bedroom-2"}


def test_a_users_adjacency_replaces_the_templates_for_that_pair() -> None:
    problem = Problem.model_validate(templated(
        ["kitchen", "dining", "living"], adjacency=[{"a": "dining", "b": "kitchen",
                                                     "min_contact": 2.5}]))
    kitchen_dining = [adj for adj in problem.adjacency
                      if {adj.a, *adj.partners} == {"kitchen", "dining"}]
    assert [adj.min_contact for adj in kitchen_dining] == [2.5]
    assert problem.adjacency[0].min_contact == 2.5  # the user's come first


def test_bedrooms_and_living_rooms_want_an_exterior_wall_and_service_rooms_do_not() -> None:
    rooms = rooms_by_id(Problem.model_validate(templated(["foyer", *FLAT])))
    for room_id in ("living", "bedroom-1", "bedroom-2"):
        assert rooms[room_id].boundary == ["north", "south", "east", "west"]
    for room_id in ("foyer", "kitchen", "bathroom"):
        assert rooms[room_id].boundary == []


def test_the_foyer_covers_a_point_just_inside_the_entrance() -> None:
    problem = Problem.model_validate(templated(["foyer", *FLAT], entrance=[10, 3]))
    assert rooms_by_id(problem)["foyer"].positions == [(9.7, 3.0)]


# Errors.


def test_an_unknown_template_is_refused_naming_the_field() -> None:
    with pytest.raises(ValidationError) as err:
        Problem.model_validate({**templated(FLAT), "template": "office-tower"})
    assert error_locs(err) == [("template",)]
    assert "residential" in err.value.errors()[0]["msg"]


def test_an_unknown_bare_type_is_refused_naming_the_room() -> None:
    with pytest.raises(ValidationError) as err:
        Problem.model_validate(templated(["living", "bedrom", "kitchen"]))
    assert error_locs(err) == [("rooms", 1)]
    message = err.value.errors()[0]["msg"]
    assert "bedrom" in message and "bedroom" in message


def test_an_unknown_type_in_a_room_object_is_sized_as_a_generic_room() -> None:
    problem = Problem.model_validate(templated(["living", {"type": "gym"}, "kitchen"]))
    gym = rooms_by_id(problem)["gym"]
    assert gym.type == "gym" and gym.min_size and gym.target_size
    assert gym.boundary == []


def test_more_rooms_than_the_floors_allow_are_refused_naming_the_rooms() -> None:
    with pytest.raises(ValidationError) as err:
        Problem.model_validate(templated(["bedroom"] * 12, 8, 6))
    assert error_locs(err) == [("rooms",)]
    assert "free area" in err.value.errors()[0]["msg"]


def test_a_room_whose_floor_fits_nowhere_is_refused_naming_it() -> None:
    with pytest.raises(ValidationError) as err:
        Problem.model_validate(templated(["hall", "living"], 20, 2.0))
    assert ("rooms", 1) in error_locs(err)


def test_errors_in_room_objects_and_references_name_their_fields() -> None:
    with pytest.raises(ValidationError) as err:
        Problem.model_validate(templated(
            ["living", {"type": "bedroom", "min_size": [-1, 3]}]))
    assert error_locs(err) == [("rooms", 1, "min_size", 0)]
    with pytest.raises(ValidationError) as err:
        Problem.model_validate(templated(FLAT, adjacency=[{"a": "living", "b": "bedroom"}]))
    assert error_locs(err) == [("adjacency", 0, "b")]  # there are bedroom-1 and bedroom-2


def test_a_broken_outline_is_reported_by_the_problems_own_checks() -> None:
    data = templated(FLAT)
    data["boundary"] = [[0, 0], [10, 0], [0, 8], [10, 8]]
    with pytest.raises(ValidationError) as err:
        Problem.model_validate(data)
    assert ("boundary",) in error_locs(err) or ("boundary", 1) in error_locs(err)


def test_the_room_limit_holds_before_expanding() -> None:
    with pytest.raises(ValidationError) as err:
        Problem.model_validate(templated(["bedroom"] * 30, 60, 60), context={"max_rooms": 20})
    assert error_locs(err) == [("rooms",)]


def test_the_json_schema_offers_bare_types() -> None:
    rooms = TemplatedProblem.model_json_schema()["properties"]["rooms"]
    assert {"type": "string", "enum": list(KNOWN_TYPES)} in rooms["items"]["anyOf"]


# Feasible in principle.


def _l_shape(width: float, depth: float, cut: float) -> list[list[float]]:
    """An L: the rectangle minus its north-east corner beyond `cut` of each side."""
    return [[0, 0], [width, 0], [width, depth * cut], [width * cut, depth * cut],
            [width * cut, depth], [0, depth]]


OUTLINES = st.one_of(
    st.tuples(st.floats(5, 30), st.floats(5, 30)).map(
        lambda wd: [[0, 0], [wd[0], 0], [wd[0], wd[1]], [0, wd[1]]]),
    st.builds(_l_shape, st.floats(8, 30), st.floats(8, 30), st.floats(0.3, 0.7)),
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rooms=st.lists(st.sampled_from(KNOWN_TYPES), min_size=1, max_size=14),
       boundary=OUTLINES)
def test_the_template_only_makes_problems_the_precheck_finds_nothing_against(
    rooms: list[str], boundary: list[list[float]]
) -> None:
    try:
        problem = Problem.model_validate(
            {"boundary": boundary, "template": "residential", "rooms": rooms,
             "entrance": [boundary[1][0] / 2, 0]})
    except ValidationError as err:  # refused: only ever for the template's own reasons
        assert {e["type"] for e in err.errors()} <= {
            "template_rooms_too_many", "template_room_does_not_fit"}, err
        return
    assert find_impossibilities(problem, make_domain(problem)) == []


def test_the_example_and_its_committed_expansion_agree() -> None:
    """examples/flat-7-template.expanded.json is what `floorplan solve --expand` writes;
    regenerate it when the template changes."""
    examples = EXAMPLES
    templated_file = examples / "flat-7-template.json"
    expanded_file = examples / "flat-7-template.expanded.json"
    assert Problem.model_validate_json(templated_file.read_text()) == (
        Problem.model_validate_json(expanded_file.read_text()))


def test_expand_is_the_same_as_validating() -> None:
    data = templated(["foyer", *FLAT], entrance=[2, 0])
    assert Problem.model_validate(expand(TemplatedProblem.model_validate(data))) == (
        Problem.model_validate(data))


# Solved for real.


def test_a_templated_six_room_flat_solves_to_a_valid_reachable_layout() -> None:
    problem = Problem.model_validate(templated(
        ["foyer", "living", "kitchen", "bedroom", "bedroom", "bathroom"], 10, 8,
        # Ended at its first good layout (valid, 99 % covered), well before the limit.
        entrance=[2, 0], options={"time_limit": 30, "seed": 0, "stop_when_good": True}))
    layout = solve(problem)
    report = layout.report
    assert report.valid, [c for c in report.constraints if not c.satisfied]
    assert report.coverage > 0.95
    assert report.circulation is not None and report.circulation.reachable
    # The report checks every constraint the template added.
    checked = {(c.kind, tuple(c.rooms)) for c in report.constraints}
    assert ("size", ("bedroom-1",)) in checked and ("boundary", ("living",)) in checked
    assert sum(1 for c in report.constraints if c.kind == "adjacency") == len(
        problem.adjacency)
    assert math.isclose(sum(r.area for r in layout.rooms), 80, rel_tol=0.05)


COORDINATE = st.one_of(st.integers(-3, 40), st.floats(-1e5, 1e5, allow_nan=False))
SIZE = st.one_of(st.none(), st.tuples(st.floats(0, 50), st.floats(0, 50)))
ROOM_OBJECTS = st.fixed_dictionaries({}, optional={
    "id": st.sampled_from(["a", "bedroom-1", "living", "x"]),
    "type": st.one_of(st.sampled_from(KNOWN_TYPES), st.text(max_size=5)),
    "min_size": SIZE, "max_size": SIZE, "target_size": SIZE,
    "aspect_ratio": st.one_of(st.none(), st.tuples(st.floats(1, 5), st.floats(1, 9))),
    "positions": st.lists(st.tuples(COORDINATE, COORDINATE), max_size=2),
    "boundary": st.lists(st.sampled_from(["north", "south", 0, 1, 7]), max_size=2),
})


@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck))
@given(boundary=st.one_of(OUTLINES, st.lists(st.tuples(COORDINATE, COORDINATE), min_size=4,
                                             max_size=7)),
       rooms=st.lists(st.one_of(st.sampled_from(KNOWN_TYPES), ROOM_OBJECTS), min_size=1,
                      max_size=8),
       obstacles=st.lists(st.fixed_dictionaries({
           "x": COORDINATE, "y": COORDINATE, "width": st.floats(0.1, 20),
           "depth": st.floats(0.1, 20)}), max_size=2),
       entrance=st.one_of(st.none(), st.tuples(COORDINATE, COORDINATE)),
       adjacency=st.lists(st.fixed_dictionaries({
           "a": st.sampled_from(["living", "bedroom-1", "a", "kitchen"]),
           "b": st.sampled_from(["living", "bathroom", "x", "kitchen"])}), max_size=2))
def test_odd_templated_input_is_refused_with_located_errors_never_a_crash(
    boundary: list[Any], rooms: list[Any], obstacles: list[Any], entrance: Any,
    adjacency: list[Any],
) -> None:
    data = {"boundary": boundary, "template": "residential", "rooms": rooms,
            "obstacles": obstacles, "entrance": entrance, "adjacency": adjacency}
    try:
        problem = Problem.model_validate(data)
    except ValidationError as err:
        assert all(e["loc"] for e in err.errors())
        return
    assert "template" not in problem.model_dump()
