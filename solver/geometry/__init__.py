"""Plane geometry for layouts: the domain as bounding box minus blocked rectangles
(paper Sec. 5.3), boundary edges with their compass facing, and shapely helpers.

The modules: `boxes` (`Box`, the grid and the tolerance), `regions` (rectilinear
regions as rectangles), `domain` (the domain, the outline's edges, the notches),
`walls` (the walls rooms share), `snapping` (coordinates snapped, walls lined up).
Every public name is importable from here.
"""

from __future__ import annotations

from floorplan.solver.geometry.boxes import (
    EPS,
    GRID,
    Box,
    GeometryError,
    bounding_box,
    encloses,
)
from floorplan.solver.geometry.domain import (
    WRAP_MARGIN,
    Domain,
    Edge,
    Facing,
    Notch,
    boundary_edges,
    compass_words,
    domain_lines,
    edges_named,
    make_domain,
    notches_of,
    on_edge,
    unwrapped,
)
from floorplan.solver.geometry.regions import (
    largest_box_around,
    polygon_coords,
    rectangles_of,
    room_polygon,
    unusable_space,
)
from floorplan.solver.geometry.snapping import (
    snap_map,
    snap_rooms,
    wall_moves,
    wall_runs,
    walls_moved,
)
from floorplan.solver.geometry.walls import (
    contact_length,
    longest_shared_wall,
    shared_wall_length,
    straight_stretches,
)

__all__ = [
    "EPS",
    "GRID",
    "WRAP_MARGIN",
    "Box",
    "Domain",
    "Edge",
    "Facing",
    "GeometryError",
    "Notch",
    "boundary_edges",
    "bounding_box",
    "compass_words",
    "contact_length",
    "domain_lines",
    "edges_named",
    "encloses",
    "largest_box_around",
    "longest_shared_wall",
    "make_domain",
    "notches_of",
    "on_edge",
    "polygon_coords",
    "rectangles_of",
    "room_polygon",
    "shared_wall_length",
    "snap_map",
    "snap_rooms",
    "straight_stretches",
    "unusable_space",
    "unwrapped",
    "wall_moves",
    "wall_runs",
    "walls_moved",
]
