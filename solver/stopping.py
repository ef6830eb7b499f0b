"""Stopping a solve at a good-enough layout (batches; docs/cli.md, "floorplan batch"): a
batch wants many good plans, not each one's last hundredths of Eq. 12.

`GoodEnough` is an `on_event` sink for `solve` whose `reached` makes its `should_stop`:
it turns true at the first incumbent that passes the checker (the layout as `solve`
would return it then: gaps absorbed), covers `coverage` of the floor and has an Eq. 12
of at most `bound` (``math.inf``: any Eq. 12). Eq. 12 is the problem's own, as the
report measures it (with `options.diverse` the search aims at sizes the seed drew,
solver/heuristics/variety.py, and its incumbents' objectives are of those). The solve
then ends as if interrupted, and its answer is checked again as any answer is.
"""

from __future__ import annotations

from floorplan.models import Layout, Problem
from floorplan.solver.events import Phase, SolveEvent
from floorplan.solver.geometry import Box
from floorplan.solver.verify.checker import check_layout

#: Share of the floor a layout must cover to be good enough, by default.
DEFAULT_COVERAGE = 0.99
#: m² of slack in the quick test of an incumbent's area before it is checked.
AREA_TOL = 1e-3


class GoodEnough:
    """Pass as ``solve(problem, on_event=good, should_stop=good.is_reached)``."""

    def __init__(self, problem: Problem, bound: float, *,
                 coverage: float = DEFAULT_COVERAGE) -> None:
        self.problem = problem
        self.bound = bound
        self.coverage = coverage
        self.reached = False
        #: The good incumbent's rooms, once `reached`: what the solve should return.
        self.rooms: dict[str, list[Box]] | None = None
        self._free_area = float(problem.free_area().area)

    def is_reached(self) -> bool:
        """The solve's `should_stop`."""
        return self.reached

    def __call__(self, event: SolveEvent) -> None:
        if (self.reached or event.phase is not Phase.INCUMBENT or event.rooms is None
                or event.floor):
            return
        if not self.problem.options.diverse and (
                event.objective is None or event.objective > self.bound):
            return  # the event's Eq. 12 is the problem's: no check needed to refuse it
        area = sum(b.width * b.depth for boxes in event.rooms.values() for b in boxes)
        if area < self.coverage * self._free_area - AREA_TOL:
            return  # the rooms do not overlap: too little floor in them to cover enough
        check = check_layout(self.problem, event.rooms)
        w = self.problem.weights
        objective = w.cover * check.uncovered_area + w.size * sum(check.size_error.values())
        self.reached = (check.valid and check.coverage >= self.coverage
                        and objective <= self.bound)
        if self.reached:
            # SCIP may report one more incumbent before it stops, not necessarily good.
            self.rooms = event.rooms


def good_rank(layout: Layout) -> tuple[bool, bool, float]:
    """How a finished layout ranks among tries of one brief: good (valid, covering
    `DEFAULT_COVERAGE`) first, then valid, then the larger coverage."""
    r = layout.report
    return (r.valid and r.coverage >= DEFAULT_COVERAGE, r.valid, r.coverage)
