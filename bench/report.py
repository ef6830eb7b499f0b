"""Medians over repeats, machine facts, and the outputs: results.json, results.md,
complexity.png and a profile-<case>.png per case (bench/anytime.py)."""

from __future__ import annotations

import datetime
import importlib.util
import json
import math
import os
import platform
import statistics
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.anytime import FINAL_WITHIN, cases_with_profiles, plot_profiles, profile_rows
from bench.evaluate import RunRecord
from floorplan.models import Problem

#: Figures whose median is taken over the runs.
MEDIAN_FIELDS = ("first_valid", "first_pass", "final_time", "last_improvement", "coverage",
                 "hard_violations", "size_error", "objective")
#: Times where a run that found nothing counts as +infinity (so "none" wins a majority).
TIME_FIELDS = frozenset({"first_valid", "first_pass"})
#: Measurements of the final layout whose lowest and highest value over the runs are
#: reported beside the median: the spread between seeds is often larger than the
#: difference between two solvers, and a median alone hides it.
SPREAD_FIELDS = ("coverage", "size_error", "objective")


def complexity(problem: Problem) -> dict[str, int]:
    """Constraint counts as the paper's Table 1 gives them (size, overlap, ratio, pos,
    boundary, adjacency: one per room that has the constraint, one overlap per room,
    one per adjacency requirement), their total, and rooms + total, the complexity of
    its Fig. 18."""
    rooms = problem.rooms
    counts = {
        "size": sum(1 for r in rooms if r.min_size or r.max_size or r.target_size),
        "overlap": len(rooms),
        "ratio": sum(1 for r in rooms if r.aspect_ratio is not None),
        "pos": sum(1 for r in rooms if r.positions),
        "boundary": sum(1 for r in rooms if r.boundary),
        "adjacency": len(problem.adjacency),
    }
    total = sum(counts.values())
    return {**counts, "total": total, "rooms": len(rooms), "complexity": len(rooms) + total}


def median(values: Sequence[float | None], *, none_is_inf: bool) -> float | None:
    """Median of the runs; `None` (nothing found) counts as +inf for times, and is left
    out for measurements of a final layout."""
    if none_is_inf:
        xs = [math.inf if v is None else float(v) for v in values]
    else:
        xs = [float(v) for v in values if v is not None]
    if not xs:
        return None
    m = statistics.median(xs)
    return None if math.isinf(m) else m


def summarise(records: Sequence[RunRecord]) -> dict[str, Any]:
    """Medians of one case and solver."""
    out: dict[str, Any] = {"runs": len(records)}
    for name in MEDIAN_FIELDS:
        out[name] = median([getattr(r, name) for r in records], none_is_inf=name in TIME_FIELDS)
    for name in SPREAD_FIELDS:
        values = [float(v) for r in records if (v := getattr(r, name)) is not None]
        out[f"{name}_range"] = [min(values), max(values)] if values else None
    out["found_valid"] = sum(1 for r in records if r.first_valid is not None)
    out["found_pass"] = sum(1 for r in records if r.first_pass is not None)
    out["final_valid"] = sum(1 for r in records if r.valid)
    out["time_limit"] = max(r.time_limit for r in records)
    out["errors"] = [r.status for r in records if r.status.startswith("error")]
    return out


def machine_info() -> dict[str, Any]:
    """CPU model, cores, Python, pyscipopt and SCIP versions, date."""
    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    import pyscipopt

    scip = pyscipopt.Model()
    version = f"{scip.getMajorVersion()}.{scip.getMinorVersion()}.{scip.getTechVersion()}"
    scip.freeProb()
    return {
        **_revision(),
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "pyscipopt": pyscipopt.__version__,
        "scip": version,
        "platform": platform.platform(),
        # Other work on the machine slows every solver: the load as the run started.
        "load_average": [round(x, 2) for x in os.getloadavg()],
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
    }


def _revision() -> dict[str, Any]:
    """The commit the solver code came from, and whether its files differed from it."""
    root = Path(__file__).resolve().parent.parent
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "solver", "models"],
                               cwd=root, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return {"commit": None, "solver_modified": None}
    return {"commit": head, "solver_modified": bool(dirty.strip())}


def build_results(
    cases: dict[str, Problem],
    records: Sequence[RunRecord],
    settings: dict[str, Any],
    machine: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The whole of results.json; `machine` defaults to the facts of now."""
    summary: dict[str, dict[str, Any]] = {}
    for name, problem in cases.items():
        per_solver = {}
        for solver in dict.fromkeys(r.solver for r in records if r.case == name):
            runs = [r for r in records if r.case == name and r.solver == solver]
            per_solver[solver] = summarise(runs)
        summary[name] = {**complexity(problem), "solvers": per_solver}
    return {
        "machine": machine if machine is not None else machine_info(),
        "settings": settings,
        "summary": summary,
        "runs": [r.to_json() for r in records],
    }


def has_matplotlib() -> bool:
    """Whether the optional `bench` extra's matplotlib is there to draw the pictures."""
    return importlib.util.find_spec("matplotlib") is not None


def write_outputs(results: dict[str, Any], out: Path) -> None:
    """results.json and results.md, and the pictures when matplotlib is installed
    (without it the harness still measures, and says what it did not draw)."""
    out.mkdir(parents=True, exist_ok=True)
    drawing = has_matplotlib()
    (out / "results.json").write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    (out / "results.md").write_text(markdown(results, pictures=drawing), encoding="utf-8")
    if not drawing:
        print("matplotlib is not installed (pip install -e '.[bench]'): no complexity.png "
              "and no profile-<case>.png", file=sys.stderr)
        return
    plot_complexity(results, out / "complexity.png")
    plot_profiles(results, out)


def _s(v: float | None, found: int, runs: int) -> str:
    if v is None:
        return "none" if found == 0 else f"none ({found}/{runs} found)"
    text = f"{v:.2f}" if v < 100 else f"{v:.0f}"
    return text if found in (runs, -1) else f"{text} ({found}/{runs})"


def _num(v: float | None, fmt: str) -> str:
    return "-" if v is None else format(v, fmt)


def _spread(s: dict[str, Any], name: str, fmt: str, scale: float = 1.0) -> str:
    """The median and, where the runs differ at this precision, their lowest and highest
    value (one run never does)."""
    text = _num(None if s[name] is None else scale * s[name], fmt)
    span = s.get(f"{name}_range")
    if span is None:
        return text
    low, high = (format(scale * v, fmt) for v in span)
    return text if low == high else f"{text} ({low}-{high})"


def markdown(results: dict[str, Any], *, pictures: bool = True) -> str:
    """The tables of results.md; with `pictures`, links to the profile pictures drawn
    beside it (without, a line saying they were not drawn)."""
    mach = results["machine"]
    lines = [
        "# Benchmark results",
        "",
        f"{mach['date']}, {mach['cpu']}, {mach['cores']} cores, Python {mach['python']}, "
        f"pyscipopt {mach['pyscipopt']}, SCIP {mach['scip']}. "
        f"Medians over the runs (seeds: case seed + repeat index), with the lowest and "
        f"highest run in brackets where they differ. Times in seconds on the "
        f"harness's clock; *valid* = passes the independent checker and covers >= 99 %; "
        f"*passes* = passes the checker whatever the coverage. A time of \"none\" means no "
        f"such layout in the majority of runs; (k/n) counts the runs that found one."
        + _load_note(mach),
        "",
        "| case | rooms | complexity | solver | limit (s) | runs | first valid | first passing "
        "| final | coverage | hard violations | size error | Eq. 12 objective |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, case in results["summary"].items():
        for solver, s in case["solvers"].items():
            runs = s["runs"]
            cov = "-" if s["coverage"] is None else f"{_spread(s, 'coverage', '.1f', 100)} %"
            label = solver + (f" ({len(s['errors'])} crashed)" if s.get("errors") else "")
            lines.append(
                f"| {name} | {case['rooms']} | {case['complexity']} | {label} "
                f"| {s['time_limit']:g} | {runs} "
                f"| {_s(s['first_valid'], s['found_valid'], runs)} "
                f"| {_s(s['first_pass'], s['found_pass'], runs)} "
                f"| {_s(s['final_time'], -1, runs)} | {cov} "
                f"| {_num(s['hard_violations'], 'g')} | {_spread(s, 'size_error', '.1f')} "
                f"| {_spread(s, 'objective', '.1f')} |")
    errors = [f"- {name}, {solver}: {e}" for name, case in results["summary"].items()
              for solver, s in case["solvers"].items() for e in s.get("errors", [])]
    if errors:
        lines += ["", "Runs that raised instead of returning a layout (counted as finding "
                      "none):", "", *errors]
    compared = [(name, case) for name, case in results["summary"].items()
                if {"ours", "flat"} <= set(case["solvers"])]
    if compared:
        lines += ["", "Speed-up of ours against the flat baseline (flat time / our time, "
                      "medians):", "",
                  "| case | rooms | to first valid layout | to first passing layout |",
                  "|---|---|---|---|"]
        for name, case in compared:
            cells = [_ratio(case["solvers"]["ours"], case["solvers"]["flat"], key)
                     for key in ("first_valid", "first_pass")]
            lines.append(f"| {name} | {case['rooms']} | {cells[0]} | {cells[1]} |")
        lines += ["", "Quality against the flat baseline (Eq. 12 of the final layouts, "
                      "medians; lower is better; each solver at its own limit):", "",
                  "| case | rooms | ours | flat | flat / ours | coverage ours / flat |",
                  "|---|---|---|---|---|---|"]
        lines += [_quality_row(name, case["rooms"], case["solvers"]["ours"],
                               case["solvers"]["flat"]) for name, case in compared]
    lines += _profile_section(results, pictures)
    lines.append("")
    return "\n".join(lines)


def _load_note(machine: dict[str, Any]) -> str:
    """A warning when the machine was busier than its cores as the run started: other
    work then shares the CPU, and every time in the tables is noisy."""
    load, cores = (machine.get("load_average") or [None])[0], machine.get("cores")
    if load is None or not cores or load <= cores:
        return ""
    return (f" **The machine was busy**: load {load:g} on {cores} cores as the run started "
            f"(other work shared it), so the times are noisy, and slower than on an idle "
            f"machine.")


def _profile_section(results: dict[str, Any], pictures: bool) -> list[str]:
    """Quality against time: a picture per case (bench/anytime.py) and, per solver, when
    it reached its final quality and when it returned, against its limit."""
    if not cases_with_profiles(results):
        return []
    lines = ["", "## Quality against time", ""]
    if pictures:
        lines += ["One picture per case, `profile-<case>.png` (linked below): Eq. 12 and "
                  "coverage of every recorded layout against time, one step line per run. "
                  "The recorded layouts are measured as recorded (not snapped, not "
                  "checked: the annealer's may overlap); the last point of a line is the "
                  "final layout as the table above measures it."]
    else:
        lines += ["The pictures were not drawn: matplotlib is not installed "
                  "(`pip install -e '.[bench]'`, then `python -m bench --profile-only`)."]
    lines += ["", f"*At final quality*: the first time from which Eq. 12 stays within "
              f"{100 * FINAL_WITHIN:g} % of the final layout's; *returned*: when the solver "
              f"returned its final layout. Medians over the runs, in brackets the share of "
              f"the solver's own limit.", "",
              "| case | solver | limit (s) | runs | at final quality (s) | returned (s) "
              "| final Eq. 12 |", "|---|---|---|---|---|---|---|"]
    lines += profile_rows(results, links=pictures)
    return lines


def _quality_row(name: str, rooms: int, ours: dict[str, Any], flat: dict[str, Any]) -> str:
    o, f = ours["objective"], flat["objective"]
    ratio = "-" if o is None or f is None or o <= 0 else f"{f / o:.2f}"
    covs = " / ".join("-" if s["coverage"] is None else f"{100 * s['coverage']:.1f} %"
                      for s in (ours, flat))
    return (f"| {name} | {rooms} | {_spread(ours, 'objective', '.1f')} "
            f"| {_spread(flat, 'objective', '.1f')} | {ratio} | {covs} |")


def _ratio(ours: dict[str, Any], flat: dict[str, Any], key: str) -> str:
    o, f = ours[key], flat[key]
    limit = f"{flat['time_limit']:g}"
    if o is None and f is None:
        return f"neither found one (ours within {ours['time_limit']:g} s, flat within {limit} s)"
    if f is None:
        return f"flat found none within {limit} s (ours {o:.2f} s: > {flat['time_limit'] / o:.0f}x)"
    if o is None:
        return f"ours found none within {ours['time_limit']:g} s (flat {f:.2f} s)"
    return f"{f / o:.1f}x ({f:.2f} s / {o:.2f} s)"


def plot_complexity(results: dict[str, Any], path: Path) -> None:
    """Median time to the first valid layout (left) and to the first layout passing the
    checker (right) against rooms + constraints, log-log, one series per solver; runs
    that found none are drawn hollow at their time limit."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    solvers = list(dict.fromkeys(s for c in results["summary"].values() for s in c["solvers"]))
    style = {name: (colour, marker) for name, colour, marker in zip(
        solvers, ("tab:blue", "tab:orange", "tab:green", "tab:red"), "os^D", strict=False)}
    panels = (("first_valid", "first valid layout (checker + coverage >= 99 %)"),
              ("first_pass", "first layout passing the checker"))
    for ax, (key, title) in zip(axes, panels, strict=True):
        for k, solver in enumerate(solvers):
            found, missing = [], []
            for case in results["summary"].values():
                s = case["solvers"].get(solver)
                if s is None:
                    continue
                if s[key] is not None:
                    found.append((case["complexity"], s[key]))
                else:
                    # Shifted a little per solver so equal limits stay visible.
                    missing.append((case["complexity"] * (1 + 0.03 * k), s["time_limit"]))
            colour, marker = style.get(solver, ("black", "o"))
            if found:
                ax.plot(*zip(*sorted(found), strict=True), marker=marker, color=colour,
                        label=solver)
            if missing:
                ax.plot(*zip(*sorted(missing), strict=True), marker=marker, ls="none",
                        mfc="none", color=colour, label=f"{solver}: none within its limit")
        ax.set_xscale("log")
        ax.set_yscale("log")
        # One tick per case, at its complexity.
        ticks = sorted({c["complexity"] for c in results["summary"].values()})
        ax.set_xticks(ticks)
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.tick_params(axis="x", labelsize=8, labelrotation=60)
        ax.set_xlabel("complexity: rooms + constraints (Table 1 counts)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("median time (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
