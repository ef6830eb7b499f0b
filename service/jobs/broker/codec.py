"""A sub-domain task and its outcome as JSON, field by field: what crosses Redis between
a solve and the sub-domain workers is data, never code.

Each solver dataclass that travels (`SubdomainTask` with its `LevelSpec`, `RectSpec`,
`ContactSpec`, `EnvelopeSpec`, `Refine`, `Box`, `Edge`, `Notch`; `SubdomainOutcome`)
has an explicit encoder and decoder here. Decoding checks every value's type (numbers
are numbers, not booleans nor NaN; names are strings; words are among the allowed
ones) and refuses unknown or missing fields with a `CodecError`, so a crafted message
can at worst fail to decode. Encoding refuses a dataclass whose fields are not exactly
the ones written here: a field added to the solver's data must be added here too.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import fields
from typing import Any, TypeVar, cast

from floorplan.solver.geometry import Box, Edge, Facing, Notch
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec, Refine, Split
from floorplan.solver.pipeline.subdomains import SubdomainOutcome, SubdomainTask

#: The format's version, the "v" of every payload: a mismatch is refused.
VERSION = 1
FACINGS = ("north", "south", "east", "west")
SPLITS = ("vertical", "horizontal")

Json = dict[str, Any]
T = TypeVar("T")


class CodecError(ValueError):
    """A payload that is not an encoded task or outcome of this version."""


# Encoding.


def encode_task(task: SubdomainTask) -> str:
    """`task` as JSON text (infinite sizes as the numbers `Infinity`/`-Infinity`)."""
    return json.dumps({"v": VERSION, "task": _exact(task, {
        "spec": _level(task.spec), "start": {k: _box(b) for k, b in task.start.items()},
        "budget": task.budget, "deadline": task.deadline, "seed": task.seed,
    })})


def encode_outcome(outcome: SubdomainOutcome) -> str:
    rects = None if outcome.rects is None else {k: _box(b) for k, b in outcome.rects.items()}
    return json.dumps({"v": VERSION, "outcome": _exact(outcome, {
        "status": outcome.status, "rects": rects, "objective": outcome.objective,
        "seconds": outcome.seconds,
    })})


def _exact(obj: Any, data: Json) -> Json:
    """`data`, once it names every field of `obj`'s dataclass and no other."""
    names = {f.name for f in fields(obj)}
    if names != set(data):
        raise TypeError(f"{type(obj).__name__} has fields {sorted(names)}; the codec "
                        f"writes {sorted(data)}")
    return data


def _box(b: Box) -> list[float]:
    _exact(b, {"x0": 0, "y0": 0, "x1": 0, "y1": 0})
    return [b.x0, b.y0, b.x1, b.y1]


def _edge(e: Edge) -> Json:
    return _exact(e, {"index": e.index, "start": list(e.start), "end": list(e.end),
                      "facing": e.facing})


def _notch(n: Notch) -> Json:
    return _exact(n, {"obstacle": _box(n.obstacle), "hull": _box(n.hull)})


def _refine(r: Refine) -> Json:
    return _exact(r, {"parent": _box(r.parent), "direction": r.direction, "child": r.child,
                      "delta": r.delta})


def _rect(r: RectSpec) -> Json:
    return _exact(r, {
        "name": r.name, "room": r.room, "min_size": list(r.min_size),
        "max_size": list(r.max_size), "target": None if r.target is None else list(r.target),
        "aspect_ratio": None if r.aspect_ratio is None else list(r.aspect_ratio),
        "positions": [list(p) for p in r.positions], "edges": [_edge(e) for e in r.edges],
        "refine": None if r.refine is None else _refine(r.refine),
        "fixed": None if r.fixed is None else _box(r.fixed), "soft": sorted(r.soft),
        "floor": list(r.floor), "may_wrap": r.may_wrap,
    })


def _contact(c: ContactSpec) -> Json:
    return _exact(c, {"name": c.name, "a": list(c.a), "partners": [list(g) for g in c.partners],
                      "min_contact": c.min_contact, "soft": c.soft})


def _envelope(e: EnvelopeSpec) -> Json:
    return _exact(e, {
        "room": e.room, "rects": list(e.rects),
        "previous": None if e.previous is None else _box(e.previous),
        "max_size": list(e.max_size),
        "aspect_ratio": None if e.aspect_ratio is None else list(e.aspect_ratio),
        "soft": sorted(e.soft), "min_size": list(e.min_size),
        "positions": [list(p) for p in e.positions],
    })


def _level(s: LevelSpec) -> Json:
    return _exact(s, {
        "name": s.name, "region": _box(s.region), "blocked": [_box(b) for b in s.blocked],
        "free_area": s.free_area, "rects": [_rect(r) for r in s.rects],
        "contacts": [_contact(c) for c in s.contacts],
        "envelopes": [_envelope(e) for e in s.envelopes], "cover_weight": s.cover_weight,
        "size_weight": s.size_weight, "growth_weight": s.growth_weight,
        "violation_weight": s.violation_weight, "notches": [_notch(n) for n in s.notches],
    })


# Decoding: every value checked, the path named in the error.


def decode_task(text: Any) -> SubdomainTask:
    data = _fields(_payload(text, "task"), "task", {"spec", "start", "budget", "deadline",
                                                    "seed"})
    budget = _number(data["budget"], "task.budget")
    if not math.isfinite(budget) or budget < 0:
        raise CodecError("task.budget: a finite number of seconds, at least 0")
    return SubdomainTask(
        spec=_read_level(data["spec"], "task.spec"),
        start=_box_map(data["start"], "task.start"), budget=budget,
        deadline=_number(data["deadline"], "task.deadline"),
        seed=_integer(data["seed"], "task.seed"),
    )


def decode_outcome(text: Any) -> SubdomainOutcome:
    data = _fields(_payload(text, "outcome"), "outcome",
                   {"status", "rects", "objective", "seconds"})
    return SubdomainOutcome(
        status=_string(data["status"], "outcome.status"),
        rects=None if data["rects"] is None else _box_map(data["rects"], "outcome.rects"),
        objective=_optional(data["objective"], "outcome.objective", _number),
        seconds=_number(data["seconds"], "outcome.seconds"),
    )


def _payload(text: Any, kind: str) -> Any:
    if not isinstance(text, str):
        raise CodecError(f"a {kind} travels as JSON text, not {type(text).__name__}")
    try:
        data = json.loads(text)
    except ValueError as err:
        raise CodecError(f"not JSON: {err}") from err
    if not isinstance(data, dict) or set(data) != {"v", kind}:
        raise CodecError(f'expected {{"v": {VERSION}, "{kind}": ...}}')
    if data["v"] != VERSION:
        raise CodecError(f"format version {data['v']!r}, this side reads {VERSION}")
    return data[kind]


def _fields(data: Any, path: str, names: set[str]) -> Json:
    if not isinstance(data, dict):
        raise CodecError(f"{path}: an object expected")
    if set(data) != names:
        unknown, missing = sorted(set(data) - names), sorted(names - set(data))
        raise CodecError(f"{path}: unknown fields {unknown}, missing fields {missing}")
    return cast(Json, data)


def _list(data: Any, path: str) -> list[Any]:
    if not isinstance(data, list):
        raise CodecError(f"{path}: a list expected")
    return data


def _number(data: Any, path: str) -> float:
    if isinstance(data, bool) or not isinstance(data, int | float) or math.isnan(data):
        raise CodecError(f"{path}: a number expected")
    return float(data)


def _integer(data: Any, path: str) -> int:
    if isinstance(data, bool) or not isinstance(data, int):
        raise CodecError(f"{path}: an integer expected")
    return data


def _string(data: Any, path: str) -> str:
    if not isinstance(data, str):
        raise CodecError(f"{path}: a string expected")
    return data


def _boolean(data: Any, path: str) -> bool:
    if not isinstance(data, bool):
        raise CodecError(f"{path}: true or false expected")
    return data


def _word(data: Any, path: str, allowed: tuple[str, ...]) -> str:
    if data not in allowed:
        raise CodecError(f"{path}: one of {', '.join(allowed)} expected")
    return cast(str, data)


def _optional(data: Any, path: str, read: Callable[[Any, str], T]) -> T | None:
    return None if data is None else read(data, path)


def _pair(data: Any, path: str) -> tuple[float, float]:
    items = _list(data, path)
    if len(items) != 2:
        raise CodecError(f"{path}: two numbers expected")
    return (_number(items[0], f"{path}.0"), _number(items[1], f"{path}.1"))


def _pairs(data: Any, path: str) -> tuple[tuple[float, float], ...]:
    return tuple(_pair(p, f"{path}.{k}") for k, p in enumerate(_list(data, path)))


def _strings(data: Any, path: str) -> tuple[str, ...]:
    return tuple(_string(s, f"{path}.{k}") for k, s in enumerate(_list(data, path)))


def _read_box(data: Any, path: str) -> Box:
    items = _list(data, path)
    if len(items) != 4:
        raise CodecError(f"{path}: four numbers expected (x0, y0, x1, y1)")
    x0, y0, x1, y1 = (_number(v, f"{path}.{k}") for k, v in enumerate(items))
    return Box(x0, y0, x1, y1)


def _boxes(data: Any, path: str) -> tuple[Box, ...]:
    return tuple(_read_box(b, f"{path}.{k}") for k, b in enumerate(_list(data, path)))


def _box_map(data: Any, path: str) -> dict[str, Box]:
    if not isinstance(data, dict):
        raise CodecError(f"{path}: an object expected")
    return {k: _read_box(b, f"{path}.{k}") for k, b in data.items()}


def _read_edge(data: Any, path: str) -> Edge:
    d = _fields(data, path, {"index", "start", "end", "facing"})
    return Edge(index=_integer(d["index"], f"{path}.index"),
                start=_pair(d["start"], f"{path}.start"), end=_pair(d["end"], f"{path}.end"),
                facing=cast(Facing, _word(d["facing"], f"{path}.facing", FACINGS)))


def _read_notch(data: Any, path: str) -> Notch:
    d = _fields(data, path, {"obstacle", "hull"})
    return Notch(obstacle=_read_box(d["obstacle"], f"{path}.obstacle"),
                 hull=_read_box(d["hull"], f"{path}.hull"))


def _read_refine(data: Any, path: str) -> Refine:
    d = _fields(data, path, {"parent", "direction", "child", "delta"})
    child = _integer(d["child"], f"{path}.child")
    if child not in (-1, 0, 1):
        raise CodecError(f"{path}.child: -1, 0 or 1 expected")
    return Refine(parent=_read_box(d["parent"], f"{path}.parent"),
                  direction=cast(Split, _word(d["direction"], f"{path}.direction", SPLITS)),
                  child=child, delta=_number(d["delta"], f"{path}.delta"))


def _read_rect(data: Any, path: str) -> RectSpec:
    d = _fields(data, path, {"name", "room", "min_size", "max_size", "target", "aspect_ratio",
                             "positions", "edges", "refine", "fixed", "soft", "floor",
                             "may_wrap"})
    return RectSpec(
        name=_string(d["name"], f"{path}.name"), room=_string(d["room"], f"{path}.room"),
        min_size=_pair(d["min_size"], f"{path}.min_size"),
        max_size=_pair(d["max_size"], f"{path}.max_size"),
        target=_optional(d["target"], f"{path}.target", _pair),
        aspect_ratio=_optional(d["aspect_ratio"], f"{path}.aspect_ratio", _pair),
        positions=_pairs(d["positions"], f"{path}.positions"),
        edges=tuple(_read_edge(e, f"{path}.edges.{k}")
                    for k, e in enumerate(_list(d["edges"], f"{path}.edges"))),
        refine=_optional(d["refine"], f"{path}.refine", _read_refine),
        fixed=_optional(d["fixed"], f"{path}.fixed", _read_box),
        soft=frozenset(_strings(d["soft"], f"{path}.soft")),
        floor=_pair(d["floor"], f"{path}.floor"),
        may_wrap=_boolean(d["may_wrap"], f"{path}.may_wrap"),
    )


def _read_contact(data: Any, path: str) -> ContactSpec:
    d = _fields(data, path, {"name", "a", "partners", "min_contact", "soft"})
    return ContactSpec(
        name=_string(d["name"], f"{path}.name"), a=_strings(d["a"], f"{path}.a"),
        partners=tuple(_strings(g, f"{path}.partners.{k}")
                       for k, g in enumerate(_list(d["partners"], f"{path}.partners"))),
        min_contact=_number(d["min_contact"], f"{path}.min_contact"),
        soft=_boolean(d["soft"], f"{path}.soft"),
    )


def _read_envelope(data: Any, path: str) -> EnvelopeSpec:
    d = _fields(data, path, {"room", "rects", "previous", "max_size", "aspect_ratio", "soft",
                             "min_size", "positions"})
    return EnvelopeSpec(
        room=_string(d["room"], f"{path}.room"), rects=_strings(d["rects"], f"{path}.rects"),
        previous=_optional(d["previous"], f"{path}.previous", _read_box),
        max_size=_pair(d["max_size"], f"{path}.max_size"),
        aspect_ratio=_optional(d["aspect_ratio"], f"{path}.aspect_ratio", _pair),
        soft=frozenset(_strings(d["soft"], f"{path}.soft")),
        min_size=_pair(d["min_size"], f"{path}.min_size"),
        positions=_pairs(d["positions"], f"{path}.positions"),
    )


def _read_level(data: Any, path: str) -> LevelSpec:
    d = _fields(data, path, {"name", "region", "blocked", "free_area", "rects", "contacts",
                             "envelopes", "cover_weight", "size_weight", "growth_weight",
                             "violation_weight", "notches"})

    def each(key: str, read: Callable[[Any, str], T]) -> tuple[T, ...]:
        return tuple(read(v, f"{path}.{key}.{k}")
                     for k, v in enumerate(_list(d[key], f"{path}.{key}")))

    return LevelSpec(
        name=_string(d["name"], f"{path}.name"), region=_read_box(d["region"], f"{path}.region"),
        blocked=_boxes(d["blocked"], f"{path}.blocked"),
        free_area=_number(d["free_area"], f"{path}.free_area"),
        rects=each("rects", _read_rect), contacts=each("contacts", _read_contact),
        envelopes=each("envelopes", _read_envelope),
        cover_weight=_number(d["cover_weight"], f"{path}.cover_weight"),
        size_weight=_number(d["size_weight"], f"{path}.size_weight"),
        growth_weight=_number(d["growth_weight"], f"{path}.growth_weight"),
        violation_weight=_number(d["violation_weight"], f"{path}.violation_weight"),
        notches=each("notches", _read_notch),
    )
