"""Problem -> layout, with no HTTP: the public surface.

    from solver import solve
    layout = solve(problem, on_event=print)

The names below are imported on first use, so that importing a part of the solver
(`solver.geometry`, say) does not load SCIP.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from solver.budget import default_time_limit
    from solver.events import EventSink, Phase, Solve, SolveEvent, StopFlag
    from solver.pipeline.assemble import draft_layout
    from solver.pipeline.dispatch import solve
    from solver.pipeline.pool import end_pool, subdomain_pool
    from solver.pipeline.run import layout_objective
    from solver.pipeline.subdomains import SubdomainExecutor, SubdomainTask, solve_subdomain
    from solver.verify.checker import check_layout

#: Public name -> the module that defines it.
_HOMES = {
    "solve": "solver.pipeline.dispatch",
    "SolveEvent": "solver.events",
    "Phase": "solver.events",
    "EventSink": "solver.events",
    "StopFlag": "solver.events",
    "Solve": "solver.events",
    "default_time_limit": "solver.budget",
    "check_layout": "solver.verify.checker",
    "layout_objective": "solver.pipeline.run",
    "draft_layout": "solver.pipeline.assemble",
    "SubdomainExecutor": "solver.pipeline.subdomains",
    "SubdomainTask": "solver.pipeline.subdomains",
    "solve_subdomain": "solver.pipeline.subdomains",
    "subdomain_pool": "solver.pipeline.pool",
    "end_pool": "solver.pipeline.pool",
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
        raise AttributeError(f"module 'solver' has no attribute {name!r}")
    return getattr(importlib.import_module(_HOMES[name]), name)
