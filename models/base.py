"""What every part of a problem is built on: the strict base model, the limits of
coordinates, lengths and room counts, and the field types (coordinates and lengths in
metres, points, sizes, compass words, the families of soft constraints).

A leaf of the `models` package: it imports no other module of it.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

#: Largest absolute coordinate or length we accept, in metres. Keeps big-M values sane.
MAX_COORDINATE = 1e5
#: Default cap on rooms per problem; pass ``context={"max_rooms": n}`` to change it.
DEFAULT_MAX_ROOMS = 400
#: Geometric tolerance in metres for "on the boundary" and similar tests.
TOLERANCE = 1e-6

Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-MAX_COORDINATE, le=MAX_COORDINATE)]
Length = Annotated[float, Field(allow_inf_nan=False, ge=0, le=MAX_COORDINATE)]
PositiveLength = Annotated[float, Field(allow_inf_nan=False, gt=0, le=MAX_COORDINATE)]
Point = tuple[Coordinate, Coordinate]
#: [width, depth]: width along x (east), depth along y (north).
Size = tuple[Length, Length]
Compass = Literal["north", "south", "east", "west"]
#: The constraints of a room that may be soft (`Room.soft`, `Options.strict`).
SoftFamily = Literal["min_size", "max_size", "aspect_ratio", "positions", "boundary"]
SOFT_FAMILIES: tuple[SoftFamily, ...] = (
    "min_size", "max_size", "aspect_ratio", "positions", "boundary")


class StrictModel(BaseModel):
    """The base of every part of a problem: unknown fields are refused, and a part once
    validated is frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)
