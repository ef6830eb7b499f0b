"""The gap to a known optimum (bench/README.md, "Planted briefs"): our solver and the
flat model on planted briefs (bench/planted.py), each layout measured as the planted
plan is.

    python -m bench.planted_report [--briefs DIR ...] [--seeds 2001-2012] \\
        [--solvers ours,flat] [--repeat 1] [--flat-limit 10] [--out bench/results/planted]
    python -m bench.planted_report --report-only [--out DIR]

Per brief and solver (one run each, at the seed in the brief's options; with --repeat N,
N runs at that seed and the N - 1 after it, the row then holding their medians, as the
planted goals are counted (bench/README.md, "Planted briefs"), and the runs themselves
under "runs"): valid (the checker passes the final layout and it covers >= 99 %, as in
bench/evaluate.py), coverage, mean room-area error (mean over rooms of |area - target
area| / target area, the target area being target_size[0] x target_size[1]) and Eq. 12;
the same for the plan itself. A layout is *within 2x* when it is valid and its area
error is at most twice the plan's own.
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path
from typing import Any

import shapely

from bench.evaluate import evaluate
from bench.planted import Truth, draw, load
from bench.report import machine_info, median
from bench.solvers import Rooms, run_guarded
from floorplan.models import Problem
from floorplan.solver import check_layout, layout_objective
from floorplan.solver.geometry import make_domain
from floorplan.solver.verify.checker import COVERAGE_GOAL

DEFAULT_BRIEFS = Path(__file__).resolve().parent / "data" / "planted"
#: Columns of each brief's row: the plan, then the solvers ("ours-parallel": ours with
#: a pool of one process per core, as the service and `floorplan solve` run it).
COLUMNS = ("plan", "ours", "ours-parallel", "flat")
#: A layout's area error counts as close to the plan's up to this multiple of it.
WITHIN = 2.0


def parse_seeds(text: str) -> list[int]:
    """'2001-2003,2010' -> [2001, 2002, 2003, 2010]."""
    seeds: list[int] = []
    for part in filter(None, (p.strip() for p in text.split(","))):
        lo, _, hi = part.partition("-")
        seeds.extend(range(int(lo), int(hi or lo) + 1))
    return seeds


def area_error(problem: Problem, rooms: Rooms) -> float | None:
    """Mean over the brief's rooms of |area - target area| / target area (a missing room
    counts 1); None without a layout or targets."""
    errors = []
    for room in problem.rooms:
        if room.target_size is None:
            continue
        target = room.target_size[0] * room.target_size[1]
        boxes = rooms.get(room.id, [])
        area = float(shapely.union_all([b.to_polygon() for b in boxes]).area) if boxes else 0.0
        errors.append(abs(area - target) / target)
    return sum(errors) / len(errors) if errors and rooms else None


def measure_plan(problem: Problem, truth: Truth) -> dict[str, Any]:
    """The planted plan judged as a solver's final layout is."""
    rooms = truth.boxes()
    check = check_layout(problem, rooms)
    return {"valid": check.valid and check.coverage >= COVERAGE_GOAL,
            "coverage": check.coverage, "area_error": area_error(problem, rooms),
            "objective": layout_objective(problem, make_domain(problem), rooms)}


def measure_run(problem: Problem, solver: str, name: str, flat_limit: float,
                seed: int | None = None) -> dict[str, Any]:
    """One run of `solver` through the harness's runners and `bench.evaluate`, at `seed`
    (default: the brief's own)."""
    seed = problem.options.seed if seed is None else seed
    gc.collect()
    trace = run_guarded(solver, problem, seed=seed, cap=flat_limit,
                        log=lambda text: print(text, file=sys.stderr, flush=True))
    record = evaluate(problem, make_domain(problem), trace, case=name, repeat=0, seed=seed)
    return {"valid": record.valid, "coverage": record.coverage,
            "area_error": area_error(problem, trace.final) if trace.final else None,
            "objective": record.objective, "hard_violations": record.hard_violations,
            "first_valid": record.first_valid, "seconds": round(record.final_time, 3),
            "time_limit": record.time_limit, "status": record.status}


def medians(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """One row from several runs of a solver on a brief: valid when most runs are; the
    median coverage (a run without a layout covers nothing; None when most have none),
    area error and Eq. 12 (a run without a layout counts as the worst), seconds and
    first-valid time."""
    if len(runs) == 1:
        return runs[0]
    without = sum(1 for r in runs if r["coverage"] is None)
    row = {"valid": 2 * sum(1 for r in runs if r["valid"]) > len(runs),
           "coverage": None if 2 * without > len(runs) else median(
               [r["coverage"] or 0.0 for r in runs], none_is_inf=False),
           **{key: median([r[key] for r in runs], none_is_inf=True)
              for key in ("area_error", "objective", "first_valid")},
           "hard_violations": median([r["hard_violations"] for r in runs], none_is_inf=True),
           "seconds": median([r["seconds"] for r in runs], none_is_inf=False),
           "time_limit": runs[0]["time_limit"], "status": [r["status"] for r in runs],
           "runs": runs}
    return row


def collect(briefs: list[Path], seeds: list[int]) -> list[tuple[str, Problem, Truth]]:
    """(source, brief, plan) for every pair of files in `briefs` and every seed drawn."""
    out = []
    for directory in briefs:
        for path in sorted(directory.glob("*.truth.json")):
            out.append((str(directory), *load(path)))
    out.extend(("seed", *draw(seed)) for seed in seeds)
    return out


def within(row: dict[str, Any], solver: str) -> bool:
    """The solver's layout is valid and its area error at most `WITHIN` x the plan's."""
    run, plan = row.get(solver), row["plan"]
    return bool(run and run["valid"] and run["area_error"] is not None
                and plan["area_error"] is not None
                and run["area_error"] <= WITHIN * plan["area_error"] + 1e-9)


def summarise(rows: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per column: briefs, valid count, medians of coverage, area error and Eq. 12 (over
    the briefs with a layout), and for solvers the count within 2x the plan's error."""
    out: dict[str, dict[str, Any]] = {}
    for column in COLUMNS:
        runs = [r[column] for r in rows if r.get(column)]
        if not runs:
            continue
        out[column] = {"briefs": len(runs), "valid": sum(1 for r in runs if r["valid"]),
                       "with_layout": sum(1 for r in runs if r["coverage"] is not None),
                       **{f"median_{k}": median([r[k] for r in runs], none_is_inf=False)
                          for k in ("coverage", "area_error", "objective")}}
        if column != "plan":
            out[column]["within_2x"] = sum(1 for r in rows if within(r, column))
    return out


def _f(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(0.0 if abs(v) < 1e-6 else v, fmt)


def _cell(run: dict[str, Any] | None, key: str) -> str:
    if not run:
        return "-"
    if key == "valid":
        return "yes" if run["valid"] else "no"
    if key == "coverage":
        return _f(None if run["coverage"] is None else 100 * run["coverage"], ".1f")
    return _f(run[key], ".3f" if key == "area_error" else ".1f")


def _runs(repeat: int) -> str:
    if repeat == 1:
        return "one run each"
    return (f"{repeat} runs each (seeds from the brief's on), each row their medians: valid "
            "when most runs are")


def _summary_rows(summary: dict[str, dict[str, Any]], label: str) -> list[str]:
    lines = []
    for column, t in summary.items():
        cover = None if t["median_coverage"] is None else 100 * t["median_coverage"]
        lines.append(f"| {label}{column} | {t['briefs']} | {t['with_layout']} | {t['valid']} | "
                     f"{_f(cover, '.1f')} | "
                     f"{_f(t['median_area_error'], '.3f')} | {_f(t['median_objective'], '.1f')}"
                     f" | {t.get('within_2x', '-')} |")
    return lines


def markdown(results: dict[str, Any]) -> str:
    """results.md: the medians (all briefs, then by source when there are several), then
    one row per brief."""
    m, s, rows = results["machine"], results["settings"], results["briefs"]
    lines = [
        "# Planted briefs: ours and the flat model against the planted plan", "",
        f"{m.get('date')}, commit {str(m.get('commit'))[:10]}, {m.get('cpu')}, "
        f"{m.get('cores')} cores, SCIP {m.get('scip')}. Ours at its default time limit, "
        f"flat at 10x ours capped at {s['flat_limit']:g} s; {_runs(s.get('repeat', 1))}. "
        "Area error: mean "
        "over rooms of |area - target area| / target area. Valid: the checker passes "
        "it and it covers >= 99 %. Within 2x: valid and area error <= 2x the plan's.", "",
        "Medians over the briefs with a layout.", "",
        "| | briefs | with a layout | valid | median coverage % | median area error "
        "| median Eq. 12 | within 2x the plan's error |", "|---|---|---|---|---|---|---|---|"]
    lines += _summary_rows(results["summary"], "")
    sources = list(dict.fromkeys(r.get("source", "") for r in rows))
    for source in sources if len(sources) > 1 else []:
        label = "drawn seeds" if source == "seed" else source
        lines += _summary_rows(summarise([r for r in rows if r.get("source") == source]),
                               f"{label}: ")
    keys = ("valid", "coverage", "area_error", "objective")
    shown = [c for c in COLUMNS if any(r.get(c) for r in rows)]
    lines += ["", f"Per brief: {' / '.join(shown)}.", "",
              "| brief | rooms | valid | coverage % | area error | Eq. 12 |",
              "|---|---|---|---|---|---|"]
    for r in rows:
        cells = [" / ".join(_cell(r.get(c), k) for c in shown) for k in keys]
        lines.append(f"| {r['name']} | {r['rooms']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def write(results: dict[str, Any], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    results["summary"] = summarise(results["briefs"])
    (out / "results.json").write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    (out / "results.md").write_text(markdown(results), encoding="utf-8")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m bench.planted_report", description=(
        "Ours and the flat model on planted briefs, against the planted plans."))
    p.add_argument("--briefs", type=Path, nargs="*", default=[DEFAULT_BRIEFS],
                   help="directories of NAME.json + NAME.truth.json (default: %(default)s)")
    p.add_argument("--seeds", default="", help="briefs to draw too, e.g. 2001-2012")
    p.add_argument("--solvers", default="ours,flat",
                   help="comma-separated: ours, ours-parallel, flat")
    p.add_argument("--repeat", type=int, default=1,
                   help="runs per brief and solver, at the brief's seed and the ones after "
                        "it; the row holds their medians (default: %(default)s)")
    p.add_argument("--flat-limit", type=float, default=10.0,
                   help="cap in seconds on the flat model's limit (default: %(default)s)")
    p.add_argument("--out", type=Path, default=Path("bench/results/planted"))
    p.add_argument("--report-only", action="store_true",
                   help="solve nothing: rewrite results.md from --out's results.json")
    args = p.parse_args(argv)
    args.solvers = [x.strip() for x in args.solvers.split(",") if x.strip()]
    if not set(args.solvers) <= set(COLUMNS[1:]):
        p.error("--solvers: choose from ours, ours-parallel, flat")
    if args.repeat < 1:
        p.error("--repeat: at least 1")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.report_only:
        write(json.loads((args.out / "results.json").read_text(encoding="utf-8")), args.out)
        return 0
    briefs = collect(args.briefs, parse_seeds(args.seeds))
    results: dict[str, Any] = {
        "machine": machine_info(), "settings": {
            "briefs": [str(b) for b in args.briefs], "seeds": args.seeds,
            "solvers": args.solvers, "flat_limit": args.flat_limit, "repeat": args.repeat},
        "briefs": []}
    started = time.monotonic()
    for source, problem, truth in briefs:
        row: dict[str, Any] = {"name": problem.name, "source": source,
                               "rooms": len(problem.rooms), "plan": measure_plan(problem, truth)}
        for solver in args.solvers:
            row[solver] = medians([
                measure_run(problem, solver, problem.name or "", args.flat_limit,
                            seed=problem.options.seed + k) for k in range(args.repeat)])
        results["briefs"].append(row)
        results["settings"]["seconds"] = round(time.monotonic() - started, 1)
        write(results, args.out)  # after every brief: a stopped run keeps what it measured
        print(f"{problem.name}: " + ", ".join(
            f"{c} {_cell(row.get(c), 'valid')} {_cell(row.get(c), 'area_error')}"
            for c in COLUMNS), file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
