"""The public contract: the problem a user sends and the layout we return. No solver, no HTTP.

The names below are imported on first use, not with the package, so that a module of
it that needs nothing outside the standard library (`models.formats`) loads without
pydantic, shapely or numpy: the `floorplan` command builds ``submit``'s options from it,
and ``floorplan solve`` must not load numpy before it has set up its Ctrl-C handling.

The modules: `models.parts` (the building blocks of a problem), on `models.base` (the
strict base model, the limits and field types), `models.checks` (the checks the forms
of a problem share) and `models.options` (weights, options, openings);
`models.templates` and `models.storeys` (templated problems, buildings of several
floors), `models.problem` (`Problem`, built on them all), `models.layout` (the
answer), `models.jobs` (the service's jobs as its API shows them), `models.formats`
(what a layout can be written as).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .base import DEFAULT_MAX_ROOMS
    from .corridors import Corridors, CorridorWeights, Route
    from .layout import (
        OUTSIDE,
        Aisle,
        Circulation,
        ConflictItem,
        ConflictSet,
        ConstraintCheck,
        Corridor,
        Door,
        Egress,
        ExtraRectangles,
        FloorLayout,
        Infeasibility,
        Layout,
        Rect,
        Report,
        RoomLayout,
        Termination,
        VariantInfo,
        Window,
    )
    from .options import Openings, Options, Weights
    from .parts import Adjacency, Floor, Obstacle, Region, Room, VerticalRoom
    from .problem import Problem

_WHERE = {
    ".layout": (
        "OUTSIDE", "Aisle", "Circulation", "ConflictItem", "ConflictSet", "ConstraintCheck",
        "Corridor", "Door", "Egress", "ExtraRectangles", "FloorLayout", "Infeasibility",
        "Layout", "Rect", "Report", "RoomLayout", "Termination", "VariantInfo", "Window",
    ),
    ".base": ("DEFAULT_MAX_ROOMS",),
    ".corridors": ("CorridorWeights", "Corridors", "Route"),
    ".options": ("Openings", "Options", "Weights"),
    ".parts": ("Adjacency", "Floor", "Obstacle", "Region", "Room", "VerticalRoom"),
    ".problem": ("Problem",),
}
_MODULE_OF = {name: module for module, names in _WHERE.items() for name in names}
_SUBMODULES = frozenset({
    "base", "checks", "corridors", "formats", "jobs", "layout", "options", "parts", "problem",
    "storeys", "template_rules", "templates",
})

__all__ = [
    "DEFAULT_MAX_ROOMS",
    "OUTSIDE",
    "Adjacency",
    "Aisle",
    "Circulation",
    "ConflictItem",
    "ConflictSet",
    "ConstraintCheck",
    "Corridor",
    "CorridorWeights",
    "Corridors",
    "Door",
    "Egress",
    "ExtraRectangles",
    "Floor",
    "FloorLayout",
    "Infeasibility",
    "Layout",
    "Obstacle",
    "Openings",
    "Options",
    "Problem",
    "Rect",
    "Region",
    "Report",
    "Room",
    "RoomLayout",
    "Route",
    "Termination",
    "VariantInfo",
    "VerticalRoom",
    "Weights",
    "Window",
]


def __getattr__(name: str) -> Any:
    module = _MODULE_OF.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module, __name__), name)
    elif name in _SUBMODULES:  # `import models; models.problem`, as when it was eager
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
