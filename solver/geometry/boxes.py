"""Axis-aligned rectangles, the solver's constant ones (`Box`), with the grid and the
tolerance of plane geometry."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from shapely.geometry import Polygon, box

from floorplan.models import Rect

#: Coordinates are snapped to this grid (metres) when polygons are merged.
GRID = 1e-6
#: Lengths and areas below this count as zero.
EPS = 1e-6


class GeometryError(ValueError):
    """Rectangles that do not form the shape they should."""


@dataclass(frozen=True)
class Box:
    """An axis-aligned rectangle by its corners; the solver's constant rectangles."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def depth(self) -> float:
        return self.y1 - self.y0

    @property
    def area(self) -> float:
        return self.width * self.depth

    def to_polygon(self) -> Polygon:
        return box(self.x0, self.y0, self.x1, self.y1)

    def to_rect(self) -> Rect:
        return Rect(x=self.x0, y=self.y0, width=self.width, depth=self.depth)

    @classmethod
    def of(cls, rect: Rect) -> Box:
        return cls(rect.x, rect.y, rect.x + rect.width, rect.y + rect.depth)

    def contains_point(self, x: float, y: float, tol: float = EPS) -> bool:
        return self.x0 - tol <= x <= self.x1 + tol and self.y0 - tol <= y <= self.y1 + tol


def bounding_box(boxes: Sequence[Box]) -> Box:
    """The smallest box around `boxes`."""
    return Box(min(b.x0 for b in boxes), min(b.y0 for b in boxes),
               max(b.x1 for b in boxes), max(b.y1 for b in boxes))


#: How far short of an obstacle a rectangle may stop and still enclose it (metres): SCIP
#: holds its constraints within a tolerance relative to the coordinates, and a bedroom it
#: wrapped round a shaft on an 11.5 m floor stopped 1.9e-6 short of the outline, was not
#: cut round the shaft, and failed C_inside by the shaft's whole area. The output's
#: snapping (1e-4) closes such gaps anyway.
ENCLOSE_TOL = 1e-4


def encloses(b: Box, inner: Box) -> bool:
    """Whether `b` holds `inner`, within `ENCLOSE_TOL`."""
    return (b.x0 <= inner.x0 + ENCLOSE_TOL and b.y0 <= inner.y0 + ENCLOSE_TOL
            and b.x1 >= inner.x1 - ENCLOSE_TOL and b.y1 >= inner.y1 - ENCLOSE_TOL)
