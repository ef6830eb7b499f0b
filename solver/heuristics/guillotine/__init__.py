"""Whole-floor layouts by guillotine cuts, with L- and T-shaped rooms (docs/method.md,
'Whole layouts by guillotine cuts').

Real plans are drawn wall by wall: the floor is cut in two, each part again, until
every room has its part, and a room that is an L or a T owns two neighbouring parts.
This search works in that space. A layout is a slicing tree (a Polish expression, as
in Wong and Liu's floorplanning) whose leaves are the rooms, plus a second leaf for each
room that is an L or a T. Every cut divides its region in proportion to the areas asked
of its two sides, so each room gets the area asked of it and the floor is covered by
construction; what the annealing chooses is the order of the cuts, their directions,
which rooms have a second leaf, how such a room shares its area between its two parts,
and how much area each room asks for.

The score is E_size (Eq. 6) on bounding boxes, the relative area error and a small
price per extra rectangle, plus every hard constraint a room can break (C_size Eq. 5,
C_ratio Eq. 7, C_pos Eq. 8, C_boundary Eq. 9, C_adj Eq. 10, a connected shape within
its rectangle cap and arms wide enough) priced by its shortfall. Only layouts that break
none are kept, and the caller's checker has the last word.

The annealing starts, cool, from the exact tilings of the floor by the targets where
there are any (solver/heuristics/tiling.py), on three models of the floor; from random
trees it reaches about three times the plan's score at best (bench/NOTES.md), so it
starts from those only for small floors.

Why: the MIQP's first layout fixes which room lies next to which, and everything after
it (the hierarchy, the reshaping) moves walls locally; an annealing over slicing trees
changes that topology globally, and a plan drawn as real ones are is one of its states.

The modules: `brief` (the problem in the search's numbers, and a state of the search),
`tree` (slicing trees and the rooms' rectangles under one), `score` (what the annealing
lowers), `moves` (its changes of a tree), `anneal` (the annealing and the polish),
`mirror` (the halves of a tiling's cuts), `search` (`guillotine_layout`, the whole).
"""

from __future__ import annotations

from floorplan.solver.heuristics.guillotine.search import (
    MAX_ROOMS,
    MAX_TILED_ROOMS,
    GuillotineResult,
    applies,
    guillotine_layout,
)

__all__ = ["MAX_ROOMS", "MAX_TILED_ROOMS", "GuillotineResult", "applies", "guillotine_layout"]
