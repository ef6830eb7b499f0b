"""Layouts per second of a batch: ``python -m bench batch`` (bench/README.md, "Batches").

    python -m bench batch [--count N] [--processes P] [--out FILE] [--table FILE] [BRIEF ...]

Each brief (default: apartment-5 and house-13 of bench/data/cases, and the templated
7-room flat of examples/) is laid out `--count` times on a warm pool of `--processes`
processes, by our solver as `floorplan batch` runs it (``options.diverse``, the batch's
per-layout time limit, each solve stopped at its first good layout, options.stop_when_good,
and laid out again under another draw when it is not good, `REDRAWS` times at most; a
good layout whose plan the batch holds has its walls moved apart from the plans near it,
solver/pipeline/spread.py)
and by the annealing baseline (bench/anneal.py) given the same time per layout, in the
same run. Reported per brief and solver: layouts per second (wall clock), the share
valid with coverage >= 0.99, the share of distinct plans (solver.distinct), the
adjacency graphs, and the median Eq. 12 against the brief's own targets. The pool is
the standard library's: bench may not import service.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

from floorplan.models import Layout, Problem, Report, RoomLayout
from floorplan.models.options import REDRAW_SEED_STEP
from floorplan.solver.distinct import NEAR_SHARE, DistinctPlans
from floorplan.solver.stopping import good_rank

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "bench" / "data" / "cases"
DEFAULT_BRIEFS = (CASES / "apartment-5.json", CASES / "house-13.json",
                  ROOT / "examples" / "flat-7-template.json")
#: As service.batch's defaults (bench may not import service): seconds per room, least.
SECONDS_PER_ROOM = 0.4
MIN_SECONDS = 1.0
GOOD_COVERAGE = 0.99
#: As service.batch: a layout that is not good is laid out again this many times at
#: most, the redraw's seed the layout's plus `REDRAW_SEED_STEP` times the attempt.
REDRAWS = 2


def per_layout_limit(problem: Problem) -> float:
    return problem.options.time_limit or max(MIN_SECONDS, SECONDS_PER_ROOM * len(problem.rooms))


def _warm() -> None:
    import floorplan.solver.pipeline.dispatch  # noqa: F401  (SCIP, once per process)


def _ours(args: tuple[dict[str, Any], int, float]) -> tuple[bool, float | None, str, str]:
    from floorplan.solver import solve

    brief, seed, limit = args
    best: tuple[tuple[bool, bool, float], Layout, Problem] | None = None
    for attempt in range(REDRAWS + 1):
        drawn = (seed + attempt * REDRAW_SEED_STEP) % 2**31
        problem = Problem.model_validate(brief).with_options(
            seed=drawn, time_limit=limit, diverse=True, stop_when_good=True)
        layout = solve(problem)
        rank = good_rank(layout)
        if best is None or rank > best[0]:
            best = (rank, layout, problem)
        if rank[0]:
            break
    assert best is not None
    (ok, _, _), layout, problem = best
    return ok, layout.report.objective, layout.model_dump_json(), problem.model_dump_json()


def _spread(args: tuple[str, str, Any, int]) -> str | None:
    """A good layout's walls moved apart from the plans near it (`others`), as JSON; None
    when they cannot be moved far enough."""
    from floorplan.solver.pipeline.spread import spread_layout

    problem_json, layout_json, others, seed = args
    moved = spread_layout(Problem.model_validate_json(problem_json),
                          Layout.model_validate_json(layout_json), others, seed=seed)
    return None if moved is None else moved.model_dump_json()


def _anneal(args: tuple[dict[str, Any], int, float]) -> tuple[bool, float | None, str]:
    from bench.anneal import anneal
    from floorplan.solver.geometry import make_domain, room_polygon
    from floorplan.solver.verify.checker import check_layout

    brief, seed, limit = args
    problem = Problem.model_validate(brief)
    result = anneal(problem, make_domain(problem), time_limit=limit, seed=seed)
    check = check_layout(problem, result.rooms)
    rooms = []
    for room_id, boxes in result.rooms.items():
        polygon = room_polygon(boxes)
        rooms.append(RoomLayout(id=room_id, type="room",
                                polygon=list(polygon.exterior.coords)[:-1],
                                rectangles=[b.to_rect() for b in boxes], area=polygon.area))
    w = problem.weights
    objective = w.cover * check.uncovered_area + w.size * sum(check.size_error.values())
    layout = Layout(rooms=rooms, report=Report(coverage=check.coverage,
                                               uncovered_area=check.uncovered_area,
                                               objective=objective))
    return (check.valid and check.coverage >= GOOD_COVERAGE, objective,
            layout.model_dump_json())


def measure(pool: ProcessPoolExecutor, processes: int, solver: str, brief: dict[str, Any],
            count: int, limit: float) -> dict[str, Any]:
    started = time.monotonic()
    plans = DistinctPlans()
    if solver == "ours":
        outcomes, spread = _ours_batch(pool, processes, brief, count, limit, plans)
    else:
        outcomes = list(pool.map(_anneal, [(brief, seed, limit) for seed in range(count)]))
        spread = 0
        for _, _, layout_json in outcomes:
            plans.add(Layout.model_validate_json(layout_json))
    seconds = time.monotonic() - started
    objectives = [objective for _, objective, _ in outcomes if objective is not None]
    return {"solver": solver, "layouts": count, "seconds": round(seconds, 2),
            "per_second": round(count / seconds, 2),
            "good": round(sum(g for g, _, _ in outcomes) / count, 3),
            "distinct": round(plans.plans / count, 3), "graphs": plans.graphs,
            "spread": spread,
            "eq12_median": round(statistics.median(objectives), 2) if objectives else None,
            "time_limit": limit}


def _ours_batch(pool: ProcessPoolExecutor, processes: int, brief: dict[str, Any], count: int,
                limit: float, plans: DistinctPlans
                ) -> tuple[list[tuple[bool, float | None, str]], int]:
    """`count` layouts of `brief` as `floorplan batch` makes them: solves handed out as
    processes free up, and a good layout whose plan `plans` holds (as counted when it
    finished) moved apart from the plans near it by another task, kept when its plan is
    then new. Returns each layout's (good, Eq. 12, JSON) and how many were moved."""
    outcomes: list[tuple[bool, float | None, str]] = []
    running: dict[Future[Any], tuple[int, tuple[bool, float | None, str, Layout] | None]] = {}
    seeds = iter(range(count))
    spread = 0

    def keep(ok: bool, objective: float | None, layout_json: str, layout: Layout) -> None:
        outcomes.append((ok, objective, layout_json))
        plans.add(layout)

    def hand_out() -> None:
        while len(running) < 2 * processes and (seed := next(seeds, None)) is not None:
            running[pool.submit(_ours, (brief, seed, limit))] = (seed, None)

    hand_out()
    while running:
        finished, _ = wait(running, return_when=FIRST_COMPLETED)
        for future in finished:
            seed, held = running.pop(future)
            if held is None:  # a solve
                ok, objective, layout_json, problem_json = future.result()
                layout = Layout.model_validate_json(layout_json)
                if ok and not plans.is_new(layout):
                    others = plans.near(layout, NEAR_SHARE)
                    running[pool.submit(_spread, (problem_json, layout_json, others, seed))] = (
                        seed, (ok, objective, layout_json, layout))
                else:
                    keep(ok, objective, layout_json, layout)
                continue
            moved_json = future.result()
            moved = None if moved_json is None else Layout.model_validate_json(moved_json)
            if moved is not None and good_rank(moved)[0] and plans.is_new(moved):
                spread += 1
                keep(True, moved.report.objective, moved_json, moved)
            else:
                keep(*held)
        hand_out()
    return outcomes, spread


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as a markdown table, ours and the annealer side by side per brief."""
    lines = ["| brief | rooms | s per layout | ours layouts/s | good | distinct | graphs | "
             "Eq. 12 median | anneal layouts/s | good | distinct | Eq. 12 median | "
             "rate ours / anneal |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    briefs = dict.fromkeys(r["brief"] for r in rows)
    for brief in briefs:
        by = {r["solver"]: r for r in rows if r["brief"] == brief}
        ours, anneal = by.get("ours"), by.get("anneal")
        if ours is None or anneal is None:
            continue
        ratio = ours["per_second"] / anneal["per_second"] if anneal["per_second"] else None
        lines.append(
            f"| {brief} | {ours['rooms']} | {ours['time_limit']:g} | {ours['per_second']:.2f} "
            f"| {ours['good']:.0%} | {ours['distinct']:.0%} | {ours['graphs']} "
            f"| {_num(ours['eq12_median'])} | {anneal['per_second']:.2f} "
            f"| {anneal['good']:.0%} | {anneal['distinct']:.0%} "
            f"| {_num(anneal['eq12_median'])} | {_num(ratio)} |")
    return "\n".join(lines) + "\n"


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(prog="python -m bench batch", description=__doc__.split("\n\n")[0])
    p.add_argument("briefs", nargs="*", type=Path, default=list(DEFAULT_BRIEFS))
    p.add_argument("--count", type=int, default=50, help="layouts per brief and solver")
    p.add_argument("--processes", type=int, default=2)
    p.add_argument("--out", type=Path, help="also write the rows as JSON here")
    p.add_argument("--table", type=Path, help="also write the rows as a markdown table here")
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
                       **measure(pool, args.processes, solver, brief, args.count, limit)}
                rows.append(row)
                print(f"{row['brief']:18} {solver:6} {row['per_second']:6.2f} layouts/s  "
                      f"good {row['good']:.0%}  distinct {row['distinct']:.0%}  "
                      f"graphs {row['graphs']}  Eq. 12 {_num(row['eq12_median'])}  "
                      f"({row['time_limit']:g} s each)",
                      file=sys.stderr, flush=True)
    if args.out is not None:
        args.out.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    if args.table is not None:
        args.table.write_text(table(rows), encoding="utf-8")
    return 0
