"""A programme drawn at random from a templated brief (``--vary program``; docs/cli.md,
"floorplan batch"): room counts and sizes vary from seed to seed within what the
template allows, so a batch of one brief gives flats of different programmes.

From the brief's rooms, a room given as a bare type (``"bedroom"``, not an object the
user pinned down) whose type is in `OPTIONAL_TYPES` is left out with probability
`DROP_CHANCE` (never the last of its type); with probability `ADD_CHANCE` one more room
of a type in `REPEATABLE_TYPES` the brief already has is added. The template then sizes
the programme for the outline, and each templated room's target is drawn within
`SIZE_SPREAD` of the template's, inside the template's minimum and maximum. A draw
the template refuses (its smallest rooms do not fit) is drawn again, at most `DRAWS`
times; then the brief is kept as it is.
"""

from __future__ import annotations

import random
from typing import Any

from pydantic import ValidationError

from .problem import Problem

#: Room types a drawn programme may leave out (when the brief names them as bare types).
OPTIONAL_TYPES = frozenset({"bedroom", "study", "dining", "storage", "wc", "closet",
                            "office", "laundry"})
#: Room types a drawn programme may have one more of.
REPEATABLE_TYPES = frozenset({"bedroom", "study", "bathroom", "wc", "storage"})
DROP_CHANCE = 0.3
ADD_CHANCE = 0.4
#: A templated room's target is drawn within this share of the template's own.
SIZE_SPREAD = 0.2
#: Draws tried before the brief is kept as it is.
DRAWS = 5


def vary_programme(brief: dict[str, Any], seed: int) -> Problem:
    """The problem of a programme drawn from the templated `brief` (JSON as sent) with
    `seed`; a brief without a template is validated as it is."""
    if not brief.get("template"):
        return Problem.model_validate(brief)
    rng = random.Random(seed)
    for _ in range(DRAWS):
        rooms = _draw_rooms(brief["rooms"], rng)
        try:
            problem = Problem.model_validate({**brief, "rooms": rooms})
        except ValidationError:
            continue
        return _draw_sizes(problem, rooms, rng)
    return Problem.model_validate(brief)


def _draw_rooms(rooms: list[Any], rng: random.Random) -> list[Any]:
    types = [r if isinstance(r, str) else r.get("type") for r in rooms]
    out = []
    for k, room in enumerate(rooms):
        bare = isinstance(room, str)
        kind = types[k]
        others = sum(1 for j, t in enumerate(types) if t == kind and j != k)
        if bare and kind in OPTIONAL_TYPES and others and rng.random() < DROP_CHANCE:
            continue
        out.append(room)
    repeatable = sorted({t for t in types if t in REPEATABLE_TYPES})
    if repeatable and rng.random() < ADD_CHANCE:
        out.append(rng.choice(repeatable))
    return out


def vary_sizes(problem: Problem, seed: int) -> Problem:
    """`problem` with every room's target drawn within `SIZE_SPREAD` of its own, inside
    the room's bounds (``--vary sizes``): the brief's ranges say what sizes it allows,
    its targets which it prefers; a batch may want the whole range."""
    if problem.floors is not None:
        return problem
    rng = random.Random(seed)
    return _draw_sizes(problem, {room.id for room in problem.rooms}, rng)


def _draw_sizes(problem: Problem, drawn: set[str] | list[Any], rng: random.Random) -> Problem:
    """Each room in `drawn` (ids, or the brief's room list whose bare types are drawn)
    gets a target drawn around its own, within its bounds."""
    if isinstance(drawn, list):
        drawn = {room.id for room, sketch in zip(problem.rooms, drawn, strict=True)
                 if isinstance(sketch, str)}
    changed = []
    for room in problem.rooms:
        if room.id not in drawn or room.target_size is None:
            changed.append(room)
            continue
        lo = room.min_size or (0.0, 0.0)
        hi = room.max_size or (float("inf"), float("inf"))
        target = tuple(
            round(min(max(t * rng.uniform(1 - SIZE_SPREAD, 1 + SIZE_SPREAD), lo[a]), hi[a]), 2)
            for a, t in enumerate(room.target_size))
        changed.append(room.model_copy(update={"target_size": target}))
    return problem.model_copy(update={"rooms": changed})
