"""Solving the network IP with SCIP: a time limit, a seed, the chosen edges back."""

from __future__ import annotations

import time
from dataclasses import dataclass
from enum import StrEnum

from floorplan.solver.network.formulation import NetworkSpec, build_network
from floorplan.solver.network.start import greedy_network, start_values

#: Relative gap at which the network counts as solved (the paper stops at 0.01 %, Sec. 5.3;
#: a corridor plan gains nothing visible below 0.1 %).
GAP_LIMIT = 1e-3
#: Share of the time limit the start's repair (`repair.repaired_network`) may take when no
#: closed-form start is valid.
REPAIR_SHARE = 0.5
#: SCIP's memory limit in MiB.
MEMORY_LIMIT_MB = 2048


class NetworkStatus(StrEnum):
    OPTIMAL = "optimal"
    FEASIBLE = "feasible"  # stopped at the time limit with a network
    INFEASIBLE = "infeasible"
    NO_SOLUTION = "no_solution"  # stopped at the time limit without one


@dataclass(frozen=True)
class NetworkResult:
    status: NetworkStatus
    edges: list[int]  # indices into the mesh's edges, active in the best network
    objective: float | None
    bound: float | None
    seconds: float

    @property
    def found(self) -> bool:
        return self.status in (NetworkStatus.OPTIMAL, NetworkStatus.FEASIBLE)


def solve_network(
    spec: NetworkSpec, *, time_limit: float, seed: int = 0, start: bool = True
) -> NetworkResult:
    """The best network SCIP finds for `spec` within `time_limit` seconds; with `start`,
    from a greedy network (`start.greedy_network`): on a floor of some 400 edges SCIP
    found no network at all in 40 s without one (bench/NOTES.md, "Corridors"). Where no
    closed-form start is valid, a repair search makes one (in `REPAIR_SHARE` of the time)."""
    started = time.monotonic()
    nm = build_network(spec)
    m = nm.model
    first = greedy_network(spec, repair_seconds=time_limit * REPAIR_SHARE) if start else None
    if first is not None:
        values = start_values(nm, first)
        sol = m.createSol()
        for var in m.getVars():
            m.setSolVal(sol, var, values.get(var.name, 0.0))
        m.addSol(sol)
        # Should the closed form miss a bound (an uneven pitch), SCIP completes the edges.
        partial = m.createPartialSol()
        for var in nm.E.values():
            m.setSolVal(partial, var, values[var.name])
        m.addSol(partial)
    m.hideOutput()
    m.setParam("limits/time", max(0.1, time_limit - (time.monotonic() - started)))
    m.setParam("limits/gap", GAP_LIMIT)
    m.setParam("limits/memory", MEMORY_LIMIT_MB)
    m.setParam("randomization/randomseedshift", seed)
    m.optimize()
    seconds = time.monotonic() - started
    status = m.getStatus()
    if m.getNSols() == 0:
        kind = NetworkStatus.INFEASIBLE if status == "infeasible" else NetworkStatus.NO_SOLUTION
        return NetworkResult(kind, [], None, None, seconds)
    sol = m.getBestSol()
    edges = [x for x, var in nm.E.items() if m.getSolVal(sol, var) > 0.5]
    kind = NetworkStatus.OPTIMAL if status in ("optimal", "gaplimit") else NetworkStatus.FEASIBLE
    return NetworkResult(kind, edges, float(m.getSolObjVal(sol)), float(m.getDualbound()), seconds)
