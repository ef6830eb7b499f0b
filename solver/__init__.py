"""Problem -> layout, with no HTTP: the public surface.

    from floorplan.solver import solve
    layout = solve(problem, on_event=print)

The names below are imported on first use, so that importing a part of the solver
(`solver.geometry`, say) does not load SCIP.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from floorplan.solver.budget import default_time_limit
    from floorplan.solver.events import EventSink, Phase, Solve, SolveEvent, StopFlag
    from floorplan.solver.pipeline.assemble import draft_layout
    from floorplan.solver.pipeline.dispatch import solve
    from floorplan.solver.pipeline.pool import end_pool, subdomain_pool
    from floorplan.solver.pipeline.run import layout_objective
    from floorplan.solver.pipeline.subdomains import (
        SubdomainExecutor,
        SubdomainTask,
        solve_subdomain,
    )
    from floorplan.solver.verify.checker import check_layout

#: Public name -> the module that defines it.
_HOMES = {
    "solve": "floorplan.solver.pipeline.dispatch",
    "SolveEvent": "floorplan.solver.events",
    "Phase": "floorplan.solver.events",
    "EventSink": "floorplan.solver.events",
    "StopFlag": "floorplan.solver.events",
    "Solve": "floorplan.solver.events",
    "default_time_limit": "floorplan.solver.budget",
    "check_layout": "floorplan.solver.verify.checker",
    "layout_objective": "floorplan.solver.pipeline.run",
    "draft_layout": "floorplan.solver.pipeline.assemble",
    "SubdomainExecutor": "floorplan.solver.pipeline.subdomains",
    "SubdomainTask": "floorplan.solver.pipeline.subdomains",
    "solve_subdomain": "floorplan.solver.pipeline.subdomains",
    "subdomain_pool": "floorplan.solver.pipeline.pool",
    "end_pool": "floorplan.solver.pipeline.pool",
}

__all__ = [
    "EventSink",
    "Phase",
    "Solve",
    "SolveEvent",
    "StopFlag",
    "SubdomainExecutor",
    "SubdomainTask",
    "check_layout",
    "default_time_limit",
    "draft_layout",
    "end_pool",
    "layout_objective",
    "solve",
    "solve_subdomain",
    "subdomain_pool",
]


def __getattr__(name: str) -> Any:
    if name not in _HOMES:
        raise AttributeError(f"module 'floorplan.solver' has no attribute {name!r}")
    return getattr(importlib.import_module(_HOMES[name]), name)
