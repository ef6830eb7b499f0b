"""Layouts per second of a batch (issue 23): ``python -m bench batch``.

    python -m bench batch [--count N] [--processes P] [--out FILE] [BRIEF ...]

Each brief (default: apartment-5 and house-13 of the shared cases, and the templated
7-room flat of examples/) is laid out `--count` times on a warm pool of `--processes`
processes, by our solver as `floorplan batch` runs it (``options.diverse``, the batch's
per-layout time limit; the first `REFERENCE_LAYOUTS` layouts solved to the end, the
others stopped at their first good layout within `TOLERANCE` of the best Eq. 12 of
those, solver.stopping) and by the annealing baseline (bench/anneal.py) given the same
time per layout, in the same run. Reported per brief and solver: layouts per second
(wall clock), the share valid with coverage >= 0.99, and the share of distinct plans
(solver.distinct). The pool is the standard library's: bench may not import service.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from models import Layout, Problem, Report, RoomLayout
from solver.distinct import DistinctPlans

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT.parent / "shared" / "bench" / "cases"
DEFAULT_BRIEFS = (CASES / "apartment-5.json", CASES / "house-13.json",
                  ROOT / "examples" / "flat-7-template.json")
#: As service.batch's defaults (bench may not import service): seconds per room, least.
SECONDS_PER_ROOM = 0.4
MIN_SECONDS = 1.0
GOOD_COVERAGE = 0.99
REFERENCE_LAYOUTS = 4
TOLERANCE = 0.5


def per_layout_limit(problem: Problem) -> float:
    return problem.options.time_limit or max(MIN_SECONDS, SECONDS_PER_ROOM * len(problem.rooms))


def _warm() -> None:
    import solver.pipeline.dispatch  # noqa: F401  (SCIP, once per process)


def _ours(args: tuple[dict[str, Any], int, float, float | None]
          ) -> tuple[bool, float | None, str]:
    from solver import solve
    from solver.stopping import GoodEnough

    brief, seed, limit, bound = args
    problem = Problem.model_validate(brief).with_options(seed=seed, time_limit=limit,
                                                         diverse=True)
    good = GoodEnough(problem, bound if bound is not None else -1.0)
    layout = solve(problem, on_event=good, should_stop=lambda: good.reached)
    ok = layout.report.valid and layout.report.coverage >= GOOD_COVERAGE
    return ok, layout.report.objective, layout.model_dump_json()


def _anneal(args: tuple[dict[str, Any], int, float, float | None]
            ) -> tuple[bool, float | None, str]:
    from bench.anneal import anneal
    from solver.geometry import make_domain, room_polygon
    from solver.verify.checker import check_layout

    brief, seed, limit, _ = args
    problem = Problem.model_validate(brief)
    result = anneal(problem, make_domain(problem), time_limit=limit, seed=seed)
    check = check_layout(problem, result.rooms)
    rooms = []
    for room_id, boxes in result.rooms.items():
        polygon = room_polygon(boxes)
        rooms.append(RoomLayout(id=room_id, type="room",
                                polygon=list(polygon.exterior.coords)[:-1],
                                rectangles=[b.to_rect() for b in boxes], area=polygon.area))
    layout = Layout(rooms=rooms, report=Report(coverage=check.coverage,
                                               uncovered_area=check.uncovered_area))
    return check.valid and check.coverage >= GOOD_COVERAGE, None, layout.model_dump_json()


def measure(pool: ProcessPoolExecutor, solver: str, brief: dict[str, Any], count: int,
            limit: float) -> dict[str, Any]:
    function = _ours if solver == "ours" else _anneal
    started = time.monotonic()
    first = min(REFERENCE_LAYOUTS, count)
    outcomes = list(pool.map(function, [(brief, seed, limit, None) for seed in range(first)]))
    found = [objective for ok, objective, _ in outcomes if ok and objective is not None]
    bound = min(found) * (1 + TOLERANCE) if found else None
    outcomes += pool.map(function, [(brief, seed, limit, bound)
                                    for seed in range(first, count)])
    seconds = time.monotonic() - started
    plans = DistinctPlans()
    for _, _, layout_json in outcomes:
        plans.add(Layout.model_validate_json(layout_json))
    return {"solver": solver, "layouts": count, "seconds": round(seconds, 2),
            "per_second": round(count / seconds, 2),
            "good": round(sum(g for g, _, _ in outcomes) / count, 3),
            "distinct": round(plans.plans / count, 3), "graphs": plans.graphs,
            "time_limit": limit}


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="python -m bench batch", description=__doc__.split("\n\n")[0])
    p.add_argument("briefs", nargs="*", type=Path, default=list(DEFAULT_BRIEFS))
    p.add_argument("--count", type=int, default=50, help="layouts per brief and solver")
    p.add_argument("--processes", type=int, default=2)
    p.add_argument("--out", type=Path, help="also write the rows as JSON here")
    args = p.parse_args(argv)
    rows = []
    with ProcessPoolExecutor(args.processes, initializer=_warm) as pool:
        list(pool.map(abs, range(args.processes * 4)))  # started and warm before timing
        for path in args.briefs:
            brief = json.loads(path.read_text(encoding="utf-8"))
            problem = Problem.model_validate(brief)
            limit = per_layout_limit(problem)
            for solver in ("ours", "anneal"):
                row = {"brief": path.stem, "rooms": len(problem.rooms),
                       **measure(pool, solver, brief, args.count, limit)}
                rows.append(row)
                print(f"{row['brief']:18} {solver:6} {row['per_second']:6.2f} layouts/s  "
                      f"good {row['good']:.0%}  distinct {row['distinct']:.0%}  "
                      f"graphs {row['graphs']}  ({row['time_limit']:g} s each)",
                      file=sys.stderr, flush=True)
    if args.out is not None:
        args.out.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    return 0
