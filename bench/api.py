"""The API round trip a user of `floorplan serve` sees: ``python -m bench.api``
(bench/NOTES.md, "The API round trip").

    python -m bench.api [--cases FILE ...] [--repeat N] [--seed S] [--pause S] [--out DIR]

Starts ``python -m floorplan.service serve`` on a loopback port (the embedded mode, its
default settings; `bench.edits.Service`), lays out the first case once to warm it (not
counted), then times each case `--repeat` times, under seeds S, S+1, ..., from the POST
of `/v1/layouts` to the poll that sees the job end (polled every 10 ms), default options
otherwise, `--pause` seconds apart (default 3: a user looks at a layout before asking for
the next, and the service starts the next solve's process once a job ends, which takes
a second or two of imports; 0 times requests back to back). Each result is fetched after
the clock stops and counted good when valid and
covering at least `GOOD_COVERAGE`. Writes results.json and results.md to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import httpx2 as httpx

from bench.edits import Edit, Service
from floorplan.models import Problem

ROOT = Path(__file__).resolve().parent.parent
#: The cases issue 42 sets round-trip goals for (seconds, on 2 cores).
DEFAULT_CASES = {
    ROOT / "examples" / "apartment-5.json": 0.5,
    ROOT / "bench" / "data" / "cases" / "house-13.json": 5.0,
    ROOT / "bench" / "data" / "cases" / "residential-15.json": 5.0,
    ROOT / "bench" / "data" / "cases" / "office-40.json": 8.0,
}
GOOD_COVERAGE = 0.99
DEFAULT_OUT = ROOT / "bench" / "results" / "api"


@dataclass(frozen=True)
class Trip:
    case: str
    seed: int
    seconds: float
    status: str
    valid: bool
    coverage: float
    termination: str
    solve_time: float


def trip(service: Service, client: httpx.Client, case: str, problem: Problem,
         seed: int) -> Trip:
    brief = problem.with_options(seed=seed).model_dump(mode="json", exclude_none=True)
    seconds, status, layout = service.edit(client, Edit(case, "", 1.0, (), brief))
    if layout is None:
        return Trip(case, seed, seconds, status, False, 0.0, "", 0.0)
    r = layout.report
    return Trip(case, seed, seconds, status, r.valid, r.coverage, str(r.termination),
                r.solve_time)


def summary(trips: list[Trip], goals: dict[str, float]) -> list[dict[str, Any]]:
    rows = []
    for case, goal in goals.items():
        mine = [t for t in trips if t.case == case]
        seconds = [t.seconds for t in mine]
        rows.append({
            "case": case, "goal": goal, "runs": len(mine),
            "good": sum(t.valid and t.coverage >= GOOD_COVERAGE for t in mine),
            "median": statistics.median(seconds), "min": min(seconds), "max": max(seconds),
            "median_solve_time": statistics.median(t.solve_time for t in mine),
            "terminations": sorted({t.termination for t in mine}),
        })
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    lines = ["| case | goal (s) | runs | valid and covering | median (s) | min-max (s) "
             "| median solve_time (s) | terminations |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['goal']} | {r['runs']} | {r['good']} "
                     f"| {r['median']:.2f} | {r['min']:.2f}-{r['max']:.2f} "
                     f"| {r['median_solve_time']:.2f} | {', '.join(r['terminations'])} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.api", description=__doc__)
    parser.add_argument("--cases", nargs="*", type=Path, default=None,
                        help="problem JSON files (default: issue 42's four cases)")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pause", type=float, default=3.0,
                        help="seconds between two requests (default 3)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args(argv)
    paths = args.cases or list(DEFAULT_CASES)
    goals = {p.stem: DEFAULT_CASES.get(p.resolve(), float("nan")) for p in paths}
    problems = {p.stem: Problem.model_validate_json(p.read_text()) for p in paths}
    trips: list[Trip] = []
    with tempfile.TemporaryDirectory(prefix="bench-api-") as data:
        service = Service(Path(data))
        try:
            with httpx.Client(timeout=120) as client:
                first = next(iter(problems))
                trip(service, client, first, problems[first], args.seed)  # warm
                for k in range(args.repeat):
                    for case, problem in problems.items():
                        time.sleep(args.pause)
                        trips.append(t := trip(service, client, case, problem, args.seed + k))
                        print(f"{case} seed {t.seed}: {t.seconds:.2f} s {t.status} "
                              f"valid={t.valid} coverage={t.coverage:.3f} {t.termination}",
                              flush=True)
        finally:
            service.stop()
    rows = summary(trips, goals)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(
        {"pause": args.pause, "trips": [asdict(t) for t in trips], "summary": rows},
        indent=1))
    (args.out / "results.md").write_text(markdown(rows))
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
