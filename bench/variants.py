"""Design variants against one layout: ``python -m bench variants`` (bench/NOTES.md,
"Design variants as local re-layouts").

    python -m bench variants [--case NAME] [--seeds 0,1,2,3] [--variants 4]

Per seed, one solve with `--variants` asked, then one with a single layout, each in
this process with a 2-process sub-domain pool warmed before the clock starts (as the
service runs a solve). Prints one JSON line per solve: seconds, the variants found,
how many cover 99 %, and per variant (valid, coverage, Eq. 12, least_difference); the
events of phase `variant` say when each was found and how. Compare two trees by
running it from each, interleaved a seed at a time.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from floorplan.models import Problem
from floorplan.solver import solve
from floorplan.solver.events import Phase, SolveEvent
from floorplan.solver.pipeline.pool import end_pool, subdomain_pool
from floorplan.solver.pipeline.subdomains import SubdomainExecutor
from floorplan.solver.verify.checker import COVERAGE_GOAL

CASES = Path(__file__).resolve().parent / "data" / "cases"


def timed(problem: Problem) -> dict[str, Any]:
    """One solve of `problem` with a warmed 2-process pool, and what it found."""
    events: list[str] = []

    def on_event(event: SolveEvent) -> None:
        if event.phase is Phase.VARIANT:
            events.append(f"{event.elapsed:.1f}s {event.detail}")

    pool = subdomain_pool(2, warmed=True)
    try:
        started = time.monotonic()
        layout = solve(problem, on_event=on_event, subdomains=SubdomainExecutor(pool, 2))
        seconds = time.monotonic() - started
    finally:
        end_pool(pool)
    found = layout.variants or [layout]
    return {
        "seed": problem.options.seed, "asked": problem.options.variants,
        "seconds": round(seconds, 2), "n": len(found),
        "covering": sum(v.report.coverage >= COVERAGE_GOAL for v in found),
        "per": [(v.report.valid, round(v.report.coverage, 4),
                 None if v.report.objective is None else round(v.report.objective, 2),
                 v.report.variant.least_difference if v.report.variant else None)
                for v in found],
        "events": events, "termination": layout.report.termination.value,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench variants")
    parser.add_argument("--case", default="house-13")
    parser.add_argument("--seeds", default="0,1,2,3")
    parser.add_argument("--variants", type=int, default=4)
    args = parser.parse_args(argv)
    problem = Problem.model_validate_json((CASES / f"{args.case}.json").read_text())
    for seed in (int(s) for s in args.seeds.split(",")):
        for variants in (args.variants, 1):
            record = timed(problem.with_options(seed=seed, variants=variants))
            print(json.dumps({"case": args.case, **record}), flush=True)
    return 0
