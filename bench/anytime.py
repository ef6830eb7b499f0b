"""Quality against time, one picture per case (issue 42): Eq. 12 and coverage of every
solver's layouts as they arrive, so that ours' time policy (when it stops against its
limit, and what the time after its last gain buys) can be judged by eye, against the
flat model at its own limit.

The points come from results.json alone (`RunRecord.profile`, bench/evaluate.py), so a
committed run can be drawn again without solving (`python -m bench --profile-only`).
Matplotlib is imported only by `plot_profile`: without it the rest of the harness works.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

#: Where a case's picture goes, beside its run's results.json.
PICTURE = "profile-{case}.png"
#: A run is "at its final quality" once its Eq. 12 stays within this share of the final.
FINAL_WITHIN = 0.01
#: One colour per solver, the same in every picture; others take black.
COLOURS = {"ours": "tab:blue", "flat": "tab:orange", "anneal": "tab:green",
           "ours-parallel": "tab:purple", "ours-long": "tab:cyan"}


@dataclass
class Series:
    """One run's profile, as it is drawn: a step line through (time, value) points."""

    solver: str
    repeat: int
    times: list[float]
    objective: list[float]
    coverage: list[float]
    time_limit: float
    final_time: float
    first_valid: float | None
    valid: bool

    @property
    def reached_final(self) -> float:
        """The first time from which Eq. 12 stays within `FINAL_WITHIN` of the final's:
        when the run had the quality it returned."""
        return reached(self.times, self.objective)


def reached(times: Sequence[float], values: Sequence[float],
            within: float = FINAL_WITHIN) -> float:
    """The earliest of `times` from which every later value is within `within` (a
    share) of the last value; the last time when the values are empty of that."""
    last = values[-1]
    at = times[-1]
    for t, v in zip(reversed(times), reversed(values), strict=True):
        if v > last + within * abs(last):
            break
        at = t
    return at


def profile_series(results: dict[str, Any], case: str) -> list[Series]:
    """The runs of `case` that recorded a profile, in the order they ran."""
    out = []
    for run in results["runs"]:
        points = run.get("profile") or []
        if run["case"] != case or not points:
            continue
        t, e, c = (list(x) for x in zip(*points, strict=True))
        out.append(Series(solver=run["solver"], repeat=run["repeat"], times=t, objective=e,
                          coverage=c, time_limit=run["time_limit"],
                          final_time=run["final_time"], first_valid=run["first_valid"],
                          valid=run["valid"]))
    return out


def cases_with_profiles(results: dict[str, Any]) -> list[str]:
    """The cases of a run, in its order, with at least one profile to draw."""
    return [c for c in results["summary"] if profile_series(results, c)]


def profile_rows(results: dict[str, Any], *, links: bool = True) -> list[str]:
    """Markdown rows: per case and solver, the limit, when the run returned and when it
    reached its final quality (medians over the runs), and the final Eq. 12; with
    `links`, the case names link to their pictures."""
    rows = []
    for case in cases_with_profiles(results):
        series = profile_series(results, case)
        for solver in dict.fromkeys(s.solver for s in series):
            runs = [s for s in series if s.solver == solver]
            limit = max(s.time_limit for s in runs)
            returned = statistics.median(s.final_time for s in runs)
            at = statistics.median(s.reached_final for s in runs)
            final = statistics.median(s.objective[-1] for s in runs)
            name = f"[{case}]({PICTURE.format(case=case)})" if links else case
            rows.append(f"| {name} | {solver} | {limit:g} "
                        f"| {len(runs)} | {at:.2f} ({100 * at / limit:.0f} %) "
                        f"| {returned:.2f} ({100 * returned / limit:.0f} %) | {final:.1f} |")
    return rows


def plot_profiles(results: dict[str, Any], out: Path) -> list[Path]:
    """`profile-<case>.png` in `out` for every case with a profile; the paths written."""
    paths = []
    for case in cases_with_profiles(results):
        path = out / PICTURE.format(case=case)
        plot_profile(results, case, path)
        paths.append(path)
    return paths


def plot_profile(results: dict[str, Any], case: str, path: Path) -> None:
    """Eq. 12 (top) and coverage (bottom) against time for every run of `case`: a step
    line per run, its final layout marked (filled when valid), its first valid layout
    marked, ours' time limit and where each run of ours returned as vertical lines; a
    run that produced no layout is a cross on the time axis where it ended."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt
    from matplotlib.lines import Line2D

    series = profile_series(results, case)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(12.5, 7), sharex=True,
                                      gridspec_kw={"height_ratios": [3, 2]})
    labelled: set[str] = set()
    for s in series:
        colour = COLOURS.get(s.solver, "black")
        runs = sum(1 for o in series if o.solver == s.solver)
        label = None
        if s.solver not in labelled:
            labelled.add(s.solver)
            label = (f"{s.solver} (limit {s.time_limit:g} s"
                     + (f", {runs} runs)" if runs > 1 else ")"))
        for ax, values in ((top, s.objective), (bottom, [100 * c for c in s.coverage])):
            ax.step(s.times, values, where="post", color=colour, lw=1.6, alpha=0.85,
                    label=label if ax is top else None)
            ax.plot(s.times[-1], values[-1], "o", ms=8, color=colour,
                    mfc=colour if s.valid else "white", mew=1.8, zorder=5)
            if s.first_valid is not None:
                # The profile's times are rounded to 0.1 ms: the layout at or before it.
                k = max((i for i, t in enumerate(s.times) if t <= s.first_valid + 1e-4),
                        default=0)
                ax.plot(s.first_valid, values[k], "D", ms=5, color=colour, mfc="white",
                        zorder=5)
    # Runs without any layout have no line: a cross on the time axis where they ended.
    empty = [r for r in results["runs"] if r["case"] == case and not r.get("profile")]
    for r in empty:
        colour = COLOURS.get(r["solver"], "black")
        for ax in (top, bottom):
            ax.plot(r["final_time"], 0.03, "X", ms=9, color=colour, clip_on=False,
                    transform=ax.get_xaxis_transform(), zorder=6)
    ours = [s for s in series if s.solver == "ours"]
    for limit in sorted({s.time_limit for s in ours}):
        for ax in (top, bottom):
            ax.axvline(limit, color=COLOURS["ours"], ls="--", lw=1.2)
    for s in ours:
        for ax in (top, bottom):
            ax.axvline(s.final_time, color=COLOURS["ours"], ls=":", lw=1.2)
    objectives = [v for s in series for v in s.objective]
    if min(objectives) > 0 and max(objectives) / min(objectives) > 20:
        top.set_yscale("log")
    top.set_ylabel("Eq. 12 objective (lower is better)")
    bottom.axhline(99, color="grey", ls="-.", lw=1)
    low = min(100 * c for s in series for c in s.coverage)
    bottom.set_ylim(max(0.0, math.floor(low) - 1), 100.5)
    bottom.set_ylabel("coverage of the free floor (%)")
    bottom.set_xlabel("time since the solver was called (s, wall clock)")
    right = max([s.final_time for s in series] + [1.04 * s.time_limit for s in ours]
                + [r["final_time"] for r in empty])
    bottom.set_xlim(0, 1.02 * right)
    for ax in (top, bottom):
        ax.grid(True, which="both", alpha=0.3)
    key = [Line2D([], [], color=COLOURS.get(r["solver"], "black"), marker="X", ls="none",
                  label=f"{r['solver']} (limit {r['time_limit']:g} s): no layout, "
                        f"ended at {r['final_time']:.1f} s") for r in empty]
    key += [Line2D([], [], color="black", marker="o", ls="none",
                   label="final layout (valid: passes the checker, covers >= 99 %)"),
            Line2D([], [], color="black", marker="o", mfc="white", ls="none",
                   label="final layout (not valid)"),
            Line2D([], [], color="black", marker="D", mfc="white", ms=5, ls="none",
                   label="first valid layout")]
    if ours:
        limits = ", ".join(f"{t:g}" for t in sorted({s.time_limit for s in ours}))
        returned = ", ".join(f"{s.final_time:.2f}" for s in ours)
        key += [Line2D([], [], color=COLOURS["ours"], ls="--",
                       label=f"ours' time limit ({limits} s)"),
                Line2D([], [], color=COLOURS["ours"], ls=":",
                       label=f"ours returned ({returned} s)")]
    key.append(Line2D([], [], color="grey", ls="-.", label="coverage goal, 99 %"))
    handles, _ = top.get_legend_handles_labels()
    # Beside the panels, where it hides no line.
    top.legend(handles=handles + key, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    rooms = results["summary"].get(case, {}).get("rooms")
    machine = results.get("machine", {})
    top.set_title(f"{case}" + (f", {rooms} rooms" if rooms else "")
                  + ": quality against time, one step per recorded layout"
                  + (f"\n{machine.get('date', '')[:10]}, {machine.get('cores', '?')} cores"
                     f" shared, load {machine.get('load_average', ['?'])[0]} at the start"
                     if machine else ""), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
