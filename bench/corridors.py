"""Corridors from functional specifications against today's band aisles, and the network
IP against the stochastic edge-deletion search at equal time (Peng et al. Sec. 5.4).
`python -m bench.corridors [--out DIR]`; see bench/NOTES.md, "Corridors"."""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time
from pathlib import Path

import shapely
from shapely.geometry import Polygon

from floorplan.models import Corridors, Layout, Problem
from floorplan.solver.network.solve import REPAIR_SHARE, solve_network
from floorplan.solver.network.start import greedy_network
from floorplan.solver.network.stochastic import judge_spec, stochastic_search
from floorplan.solver.pipeline.dispatch import solve
from floorplan.solver.pipeline.regions.corridors import (
    network_spec,
    room_pitch,
    walkable_pitch,
)
from floorplan.solver.verify.egress import door_travel

CASES = Path(__file__).parent / "data" / "cases"
#: Office floors of our own, each with its `corridors` brief (exits at cores and stairs).
OWN = Path(__file__).parent / "data" / "corridors"
#: The office floor's brief: exits at both ends of its long axis.
OFFICE = {"exits": [[0, 15], [66, 15]], "width": 1.8, "max_travel": 45, "dead_ends": 6}
#: A smaller office floor (32 x 18 m) with one exit at the middle of its south side.
#: The mall: exits at the middle of its south and north sides.
MALL = {"exits": [[35, 0], [35, 34]], "width": 1.8, "max_travel": 45, "dead_ends": 6}
OFFICE_40 = {"exits": [[16, 0]], "width": 1.8, "max_travel": 30, "dead_ends": 6}


def _measure(problem: Problem, layout: Layout, exits: list[list[float]]) -> dict[str, object]:
    """Share, travel (door to nearest exit on a raster of the circulation, the same
    measure for aisles and corridors), rooms without a door onto it, size error, time."""
    shapes = [Polygon(a.polygon) for a in layout.aisles] + [
        Polygon(c.polygon) for c in layout.corridors
    ]
    names = {a.id for a in layout.aisles} | {c.id for c in layout.corridors}
    union = shapely.union_all(shapes)
    onto: dict[str, list] = {}
    for door in layout.doors:
        if door.between[0] in names:
            onto.setdefault(door.between[1], []).append(door.segment)
    travel = door_travel(union, [tuple(e) for e in exits], onto)
    finite = [t for t in travel.values() if math.isfinite(t)]
    # Where the circulation meets the facade: its own exits (today's aisles do not reach
    # the brief's exits, so they are also walked to these).
    contact = union.boundary.intersection(problem.outline().exterior)
    ends = [
        tuple(line.interpolate(0.5, normalized=True).coords[0])
        for line in getattr(contact, "geoms", [contact])
        if line.length > 0.5
    ]
    own = door_travel(union, ends, onto) if ends else {}
    own_finite = [t for t in own.values() if math.isfinite(t)]
    errors = list(layout.report.size_error.values())
    egress = layout.report.egress
    return {
        "valid": layout.report.valid,
        "rooms": len(layout.rooms),
        "share": round(float(union.area) / float(problem.free_area().area), 4),
        "max_travel": round(max(finite), 2) if finite else None,
        "mean_travel": round(statistics.fmean(finite), 2) if finite else None,
        "unreached_rooms": sum(1 for t in travel.values() if not math.isfinite(t)),
        "facade_ends": len(ends),
        "max_travel_to_facade_ends": round(max(own_finite), 2) if own_finite else None,
        "without_access": sum(1 for r in layout.rooms if r.id not in onto),
        "dead_ends": egress.dead_ends[:3] if egress else None,
        "median_size_error": round(statistics.median(errors), 3) if errors else None,
        "seconds": round(layout.report.solve_time, 1),
        "failed": [c.detail for c in layout.report.constraints if not c.satisfied][:4],
    }


def _case(case: str, brief: dict[str, object] | None) -> tuple[dict[str, object],
                                                               dict[str, object]]:
    """The case's problem without corridors and its corridors brief (`brief`, else the
    one the case carries: the floors of `OWN`)."""
    own = OWN / f"{case}.json"
    data = json.loads((own if own.exists() else CASES / f"{case}.json").read_text())
    carried = data.pop("corridors", None)
    return data, brief if brief is not None else carried


def one(case: str, seed: int, mode: str) -> dict[str, object]:
    """One solve (`mode` aisles or corridors) at `seed`, measured: what `--one` prints,
    a line per run, so two trees can be run side by side on the same loaded machine."""
    briefs = {"office-154": OFFICE, "mall-140": MALL, "office-40": OFFICE_40}
    data, brief = _case(case, briefs.get(case))
    data = {**data, "options": {**data.get("options", {}), "seed": seed}}  # type: ignore[dict-item]
    problem = Problem.model_validate({**data, "corridors": brief} if mode == "corridors"
                                     else data)
    started = time.monotonic()
    layout = solve(problem)
    wall = round(time.monotonic() - started, 1)
    head = {"case": case, "seed": seed, "mode": mode}
    if not (layout.aisles or layout.corridors):
        return {**head, "valid": layout.report.valid, "rooms": len(layout.rooms),
                "failed": [c.detail for c in layout.report.constraints if not c.satisfied][:4],
                "wall_seconds": wall}
    return {**head, **_measure(problem, layout, list(brief["exits"])),  # type: ignore[arg-type]
            "wall_seconds": wall}


def aisles_against_corridors(case: str, brief: dict[str, object]) -> dict[str, object]:
    data = json.loads((CASES / f"{case}.json").read_text())
    today = Problem.model_validate(data)
    started = time.monotonic()
    base = solve(today)
    base_seconds = time.monotonic() - started
    ours = Problem.model_validate({**data, "corridors": brief})
    started = time.monotonic()
    laid = solve(ours)
    seconds = time.monotonic() - started
    exits = list(brief["exits"])  # type: ignore[arg-type]
    return {
        "case": case,
        "aisles": {**_measure(today, base, exits), "wall_seconds": round(base_seconds, 1)},
        "corridors": {**_measure(ours, laid, exits), "wall_seconds": round(seconds, 1)},
    }


def ip_against_search(
    case: str, brief: dict[str, object] | None, seconds: float, pitch: float | None = None
) -> dict[str, object]:
    """The network IP and the stochastic search on the same spec, the same time; both
    judged by `measure.judge` (validity, Eq. 14's length and distance terms)."""
    data, brief = _case(case, brief)
    problem = Problem.model_validate({**data, "corridors": brief})
    corridors = problem.corridors
    assert isinstance(corridors, Corridors)
    if pitch is None:  # the product's grid
        spec = network_spec(problem, corridors, *walkable_pitch(
            problem, corridors, room_pitch(problem, corridors.width)))
    else:
        spec = network_spec(problem, corridors, pitch)
    out: dict[str, object] = {
        "case": case,
        "edges": len(spec.mesh.edges),
        "pitch": [round(p, 2) for p in spec.mesh.pitch],
        "seconds": seconds,
    }

    def verdict(edges: list[int]) -> dict[str, object]:
        j = judge_spec(spec, edges)
        return {
            "valid": j.valid,
            "value": round(j.value, 2),
            "length": round(j.length, 1),
            "max_walk": round(j.max_distance, 1),
            "edges": len(edges),
        }

    for name, start in (("ip", True), ("ip_cold", False)):
        result = solve_network(spec, time_limit=seconds, start=start)
        out[name] = (
            {
                **verdict(result.edges),
                "status": str(result.status),
                "bound": None if result.bound is None else round(result.bound, 2),
                "took": round(result.seconds, 1),
            }
            if result.edges
            else {"status": str(result.status), "took": round(result.seconds, 1)}
        )
    found = stochastic_search(spec, time_limit=seconds, seed=0)
    out["stochastic"] = {
        **verdict(found.edges),
        "steps": found.steps,
        "took": round(found.seconds, 1),
    }
    # The same search from the IP's own start (its time, the repair's included), for a
    # like start.
    began = time.monotonic()
    first = greedy_network(spec, repair_seconds=seconds * REPAIR_SHARE)
    if first is not None:
        left = seconds - (time.monotonic() - began)
        found = stochastic_search(spec, time_limit=left, seed=0, start=first)
        out["stochastic_from_start"] = {
            **verdict(found.edges),
            "steps": found.steps,
            "start": verdict(first)["value"],
            "took": round(time.monotonic() - began, 1),
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("bench/results/corridors"))
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--networks-only", action="store_true",
                        help="only the IP against the search; the layouts kept from the last run")
    parser.add_argument("--one", nargs=3, metavar=("CASE", "SEED", "MODE"),
                        help="one solve (MODE aisles or corridors), its measures as a JSON line")
    args = parser.parse_args()
    if args.one:
        case, seed, mode = args.one
        print(json.dumps(one(case, int(seed), mode)), flush=True)
        return
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    last = args.out / "corridors.json"
    if args.networks_only and last.exists():
        rows = json.loads(last.read_text())["layouts"]
    for case, brief in () if args.networks_only else (("office-154", OFFICE), ("mall-140", MALL)):
        rows.append(aisles_against_corridors(case, brief))
        print(json.dumps(rows[-1], indent=1), flush=True)
    networks = []
    for case, brief, pitch in (
        ("office-154", OFFICE, None),
        ("office-154", OFFICE, 5.1),
        ("office-154", OFFICE, 3.3),
        ("mall-140", MALL, None),
        ("office-40", OFFICE_40, None),
        *((path.stem, None, None) for path in sorted(OWN.glob("*.json"))),
    ):
        networks.append(ip_against_search(case, brief, args.seconds, pitch))
        print(json.dumps(networks[-1], indent=1), flush=True)
    (args.out / "corridors.json").write_text(
        json.dumps({"layouts": rows, "networks": networks}, indent=1) + "\n"
    )


if __name__ == "__main__":
    main()
