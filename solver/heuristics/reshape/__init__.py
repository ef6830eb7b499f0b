"""Reshaping a covering layout (docs/method.md, 'The steps', step 6: the size-error
trigger of paper Sec. 5.3 done by moving walls): floor passes from a room to a
neighbour across the wall they share, so a room stretched to cover the outline gives
back what a neighbour needs, and either may become an L or a T on the way, as rooms
of real plans do.

The refinement levels only grow rooms (C_refine, Eq. 13), so a room the first layout
made too large stays too large. Here a step moves one strip of floor between two rooms
(or a room and a gap), swaps two rooms' floors, or sets a room into a corner of another
while a neighbour takes its floor (`strips.nest`), and is kept when the annealing says so
(three runs from the same layout, the best kept): it may not break a constraint of the
brief more than before, and the layout returned is the best one seen that covers the
floor and has no higher Eq. 12 than the one given. What the annealing lowers is E_size
(Eq. 6, on bounding boxes) plus the relative area error (`AREA_WEIGHT`: a room's
bounding box at its target says nothing of the floor inside it) and a small price per
corner (`CORNER_WEIGHT`: of two shapes equally near the targets, the simpler).

Plain geometry on shapely polygons: no SCIP. Every candidate strip lies across one
straight stretch of a shared wall, as deep as a target or an existing corner asks.

The modules: `needs` (what a room asks of its changed shape, and what a shape costs),
`strips` (the steps: strips, nests, neighbours, gaps), `anneal` (`reshape`, the
annealing).
"""

from __future__ import annotations

from floorplan.solver.heuristics.reshape.anneal import ReshapeResult, reshape

__all__ = ["ReshapeResult", "reshape"]
