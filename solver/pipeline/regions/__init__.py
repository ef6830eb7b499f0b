"""Large layouts through regions and aisles (paper Sec. 5.3, end; Fig. 8).

1. The rooms are grouped into regions: the problem's own (`Problem.regions`, rooms in
   none forming one more region), or, above `options.regions_above` rooms, bars of
   rooms planned across the floor along the aisles (`band_regions`; where not even one
   aisle fits, a balanced partition, `auto_partition`).
2. The user's regions are laid out as rooms of a first problem (`region_problem`) by
   the ordinary `solve`: each gets its rooms' share of the floor, aisles included.
3. The walls regions share are widened into aisles of `aisle_width`, joined into one
   network reaching the entrance (`aisles.py`).
4. The rooms of each region are laid out in what is left of it, one ordinary problem
   per region part (`room_problem`), solved by `solve` with a share of the time.
5. The whole is merged, given doors (every room onto an aisle where it touches one,
   else onto a neighbour that leads to one), windows, and checked independently.
"""

from floorplan.solver.pipeline.regions.partition import regions_apply
from floorplan.solver.pipeline.regions.run import solve_regions

__all__ = ["regions_apply", "solve_regions"]
