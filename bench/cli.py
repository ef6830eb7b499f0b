"""The command line of the benchmark harness (bench/NOTES.md, "Running it").

    python -m bench [--cases DIR] [--repeat N] [--repeat-large N] [--out DIR]
                    [--only NAME ...] [--solvers ours,flat,anneal] [--flat-limit S]
    python -m bench --report-only [--out DIR] [--cases DIR]
    python -m bench --profile-only [--out DIR]   # profile-<case>.png from results.json
    python -m bench planted [options]   # planted briefs: bench/planted_report.py
    python -m bench batch [options]     # layouts per second of a batch: bench/batch.py
    python -m bench edits [options]     # edits around fixed rooms: bench/edits.py
    python -m bench variants [options]  # design variants against one layout: bench/variants.py

Cases run one after another, and on each case the solvers run one after another
(never two at once), repeat after repeat, so they share the machine equally.
"""

from __future__ import annotations

import argparse
import gc
import json
import sys
import time
from pathlib import Path

from bench.anytime import plot_profiles
from bench.batch import main as batch_main
from bench.edits import main as edits_main
from bench.evaluate import RunRecord, evaluate
from bench.planted_report import main as planted_main
from bench.report import build_results, has_matplotlib, machine_info, write_outputs
from bench.solvers import BASELINE_CAP, SOLVERS, baseline_limit, our_limit, run_guarded
from bench.variants import main as variants_main
from floorplan.models import Problem
from floorplan.solver.geometry import make_domain

#: Cases with more rooms than this run `--repeat-large` times.
LARGE_ABOVE = 20
#: The paper cases (bench/data/cases, a copy of the team's benchmark set).
DEFAULT_CASES = Path(__file__).resolve().parent / "data" / "cases"


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m bench", description=(
        "Run our solver, the flat one-model SCIP baseline and simulated annealing side "
        "by side on benchmark cases; write results.json, results.md and complexity.png."))
    p.add_argument("--cases", type=Path, default=DEFAULT_CASES,
                   help="directory of problem JSON files (default: %(default)s)")
    p.add_argument("--repeat", type=int, default=3, help="runs per case and solver")
    p.add_argument("--repeat-large", type=int, default=None,
                   help=f"runs for cases of more than {LARGE_ABOVE} rooms (default: --repeat)")
    p.add_argument("--out", type=Path, default=Path("bench/results"),
                   help="output directory (default: %(default)s)")
    p.add_argument("--only", nargs="+", default=None, metavar="NAME",
                   help="case names (file stems) to run")
    p.add_argument("--solvers", default="ours,flat,anneal",
                   help="comma-separated subset of " + ",".join(SOLVERS) + " (ours-long: "
                   "ours given the baselines' limit)")
    p.add_argument("--flat-limit", type=float, default=BASELINE_CAP,
                   help="cap in seconds on the flat baseline's and the annealer's limit, "
                        "which is otherwise 10x ours (default: %(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--report-only", action="store_true",
                   help="solve nothing: rewrite the summary, results.md and complexity.png "
                        "in --out from the runs its results.json holds")
    p.add_argument("--profile-only", action="store_true",
                   help="solve nothing: draw profile-<case>.png (quality against time) in "
                        "--out from its results.json, leaving results.json and results.md")
    args = p.parse_args(argv)
    solvers = [s.strip() for s in args.solvers.split(",") if s.strip()]
    unknown = [s for s in solvers if s not in SOLVERS]
    if unknown or not solvers:
        p.error(f"unknown solver(s) {unknown}; choose from {', '.join(SOLVERS)}")
    args.solvers = solvers
    if args.repeat < 1 or (args.repeat_large is not None and args.repeat_large < 1):
        p.error("--repeat and --repeat-large must be at least 1")
    return args


def load_cases(directory: Path, only: list[str] | None) -> dict[str, Problem]:
    files = sorted(directory.glob("*.json"))
    if only is not None:
        missing = set(only) - {f.stem for f in files}
        if missing:
            raise SystemExit(f"no case named {', '.join(sorted(missing))} in {directory}")
        files = [f for f in files if f.stem in only]
    cases = {f.stem: Problem.model_validate_json(f.read_text(encoding="utf-8")) for f in files}
    # Smallest first: the quick cases report before the long ones start.
    return dict(sorted(cases.items(), key=lambda kv: (len(kv[1].rooms), kv[0])))


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["planted"]:  # the gap to planted plans: its own report
        return planted_main(argv[1:])
    if argv[:1] == ["batch"]:  # layouts per second of a batch
        return batch_main(argv[1:])
    if argv[:1] == ["edits"]:  # edits around fixed rooms
        return edits_main(argv[1:])
    if argv[:1] == ["variants"]:  # design variants against one layout
        return variants_main(argv[1:])
    args = parse_args(argv)
    if args.report_only:
        return rewrite_report(args.out, args.cases)
    if args.profile_only:
        return redraw_profiles(args.out)
    cases = load_cases(args.cases, args.only)
    if not cases:
        print(f"no cases in {args.cases}", file=sys.stderr)
        return 2

    def log(text: str) -> None:
        if not args.quiet:
            print(text, file=sys.stderr, flush=True)

    records: list[RunRecord] = []
    started = time.monotonic()
    # Taken before any solving: the commit is the one whose code was imported.
    machine = machine_info()
    for name, problem in cases.items():
        domain = make_domain(problem)
        large = len(problem.rooms) > LARGE_ABOVE
        repeats = args.repeat_large if large and args.repeat_large is not None else args.repeat
        log(f"{name}: {len(problem.rooms)} rooms, ours {our_limit(problem):g} s, baselines "
            f"{baseline_limit(problem, args.flat_limit):g} s, {repeats} run(s)")
        for repeat in range(repeats):
            seed = problem.options.seed + repeat
            for solver in args.solvers:
                gc.collect()
                trace = run_guarded(solver, problem, seed=seed, cap=args.flat_limit, log=log)
                record = evaluate(problem, domain, trace, case=name, repeat=repeat, seed=seed)
                records.append(record)
                log(f"  {solver:6} run {repeat + 1}: first valid {_t(record.first_valid)}, "
                    f"first passing {_t(record.first_pass)}, final {record.final_time:.2f} s, "
                    f"coverage {_pct(record.coverage)}, violations {record.hard_violations}, "
                    f"objective {_f(record.objective)}")
        # Written after every case: a long run that is stopped keeps what it measured.
        settings = {
            "cases": str(args.cases), "solvers": args.solvers, "repeat": args.repeat,
            "repeat_large": args.repeat_large, "large_above": LARGE_ABOVE,
            "flat_limit": args.flat_limit, "seconds": round(time.monotonic() - started, 1),
        }
        write_outputs(build_results(
            {k: v for k, v in cases.items() if any(r.case == k for r in records)},
            records, settings, machine), args.out)
    log(f"wrote {args.out}/results.json, results.md, complexity.png, profile-<case>.png")
    return 0


def rewrite_report(out: Path, cases_dir: Path) -> int:
    """The outputs of an earlier run, from its raw runs, by today's report code: the
    tables of a committed run can follow a change to the report without re-solving."""
    path = out / "results.json"
    try:
        earlier = json.loads(path.read_text(encoding="utf-8"))
        records = [RunRecord(**run) for run in earlier["runs"]]
    except (OSError, ValueError, KeyError, TypeError) as err:
        print(f"cannot read the runs of {path}: {err}", file=sys.stderr)
        return 2
    cases = load_cases(cases_dir, list(dict.fromkeys(r.case for r in records)))
    write_outputs(build_results(cases, records, earlier["settings"], earlier["machine"]), out)
    return 0


def redraw_profiles(out: Path) -> int:
    """The pictures of quality against time of an earlier run, from its results.json:
    a change to the drawing needs no new run."""
    path = out / "results.json"
    try:
        results = json.loads(path.read_text(encoding="utf-8"))
        missing = {"runs", "summary"} - set(results)
        if missing:
            raise KeyError(", ".join(sorted(missing)))
    except (OSError, ValueError, KeyError, TypeError) as err:
        print(f"cannot read the runs of {path}: {err}", file=sys.stderr)
        return 2
    if not has_matplotlib():
        print("matplotlib is not installed (pip install -e '.[bench]'): nothing drawn",
              file=sys.stderr)
        return 1
    paths = plot_profiles(results, out)
    if not paths:
        print(f"no run in {path} recorded a profile (written before they were)",
              file=sys.stderr)
        return 1
    print(f"wrote {', '.join(str(p) for p in paths)}", file=sys.stderr)
    return 0


def _t(v: float | None) -> str:
    return "none" if v is None else f"{v:.2f} s"


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.1f} %"


def _f(v: float | None) -> str:
    return "-" if v is None else f"{v:.1f}"
