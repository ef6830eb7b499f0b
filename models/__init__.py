"""The public contract: the problem a user sends and the layout we return. No solver, no HTTP."""

from models.layout import (
    OUTSIDE,
    Circulation,
    ConstraintCheck,
    Door,
    ExtraRectangles,
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
    Openings,
    Options,
    Problem,
    Room,
    Weights,
)

__all__ = [
    "DEFAULT_MAX_ROOMS",
    "OUTSIDE",
    "Adjacency",
    "Circulation",
    "ConstraintCheck",
    "Door",
    "ExtraRectangles",
    "Infeasibility",
    "Layout",
    "Obstacle",
    "Openings",
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
