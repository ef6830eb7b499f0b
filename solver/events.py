"""What a solve tells while it runs: its phases and events, and the sink they go to."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from floorplan.models import Layout, Problem
    from floorplan.solver.geometry import Box
    from floorplan.solver.pipeline.subdomains import SubdomainExecutor


class Phase(StrEnum):
    RELAXATION = "relaxation"  # a feasibility attempt of the size-window schedule ended
    LEVEL = "level"  # a level starts
    SUBDOMAIN = "subdomain"  # a sub-domain solve ended
    CONFLICT = "conflict"  # the search for constraints that cannot hold together ended
    INCUMBENT = "incumbent"  # SCIP found a better solution of the current MIQP
    VARIANT = "variant"  # a further design variant was found (options.variants)
    DONE = "done"


@dataclass(frozen=True)
class SolveEvent:
    """Progress of a solve, for logs, progress bars and event streams."""

    phase: Phase
    level: int
    elapsed: float
    subdomain: int = 0
    subdomains: int = 0
    objective: float | None = None
    dual_bound: float | None = None
    detail: str = ""
    #: With INCUMBENT: the whole current layout, room id -> rectangles.
    rooms: dict[str, list[Box]] | None = None
    #: In a building of several storeys: the id of the floor being solved.
    floor: str = ""


EventSink = Callable[[SolveEvent], None]

#: Asked between steps: True stops the solve with the best layout found so far.
StopFlag = Callable[[], bool]


class Solve(Protocol):
    """The signature of `solver.solve`: the storeys and regions steps are given it to lay
    out each floor or part with, rather than importing it (that would be a cycle)."""

    def __call__(self, problem: Problem, *, on_event: EventSink | None = None,
                 should_stop: StopFlag | None = None,
                 subdomains: SubdomainExecutor | None = None) -> Layout: ...
