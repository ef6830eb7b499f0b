"""The public contract: the problem a user sends and the layout we return. No solver, no HTTP."""

from models.layout import (
    ConstraintCheck,
    Door,
    Infeasibility,
    Layout,
    Rect,
    Report,
    RoomLayout,
    Termination,
    Window,
)
from models.problem import (
    DEFAULT_MAX_ROOMS,
    Adjacency,
    Obstacle,
    Options,
    Problem,
    Room,
    Weights,
)

__all__ = [
    "DEFAULT_MAX_ROOMS",
    "Adjacency",
    "ConstraintCheck",
    "Door",
    "Infeasibility",
    "Layout",
    "Obstacle",
    "Options",
    "Problem",
    "Rect",
    "Report",
    "Room",
    "RoomLayout",
    "Termination",
    "Weights",
    "Window",
]
