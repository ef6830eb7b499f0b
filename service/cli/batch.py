"""`floorplan batch`: many layouts of one brief or several, on a warm process pool
(docs/cli.md, "floorplan batch").

    floorplan batch INPUT... --count N --out DIR [--processes P] [--seed S]
                    [--format json|svg|dxf|geojson] [--time-limit S] [--vary program]
                    [--tolerance T | --full] [--no-distinct | --draws K]

Each brief (a file, every ``*.json`` brief in a folder, or a templated brief) is laid out
N times, with seeds S, S+1, ... and ``options.diverse`` (service/batch.py). DIR gets
``BRIEF-SEED.EXT`` per layout, ``summary.json`` and ``summary.csv``, and a journal
(``.batch.jsonl``) of what is done: rerunning the same command skips every layout whose
file and journal line exist. Ctrl-C stops handing out layouts, ends the running ones
and writes the summary of what is done (exit 130); failed layouts (an error, a crashed
or killed process) are rows with an error, and are tried again on a rerun. A good
layout whose plan the batch holds already, once its walls were moved apart, is laid
out again under another draw (``LayoutTask.draw``), K times at most, in a hidden file until
it is kept (``--no-distinct``: never).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from collections import deque
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from floorplan.models.formats import FORMAT_NAMES, FORMATS
from floorplan.service.cli.exits import EXIT_INTERRUPTED, EXIT_NO_LAYOUT, EXIT_OK, PROG
from floorplan.service.cli.interrupt import keep_sigint_blocked

if TYPE_CHECKING:
    from floorplan.service.batch import LayoutRow, Tally

#: The journal of finished layouts in the output folder: one JSON object a line.
JOURNAL = ".batch.jsonl"
SUMMARY_JSON = "summary.json"
SUMMARY_CSV = "summary.csv"
#: The columns of summary.csv, in order.
CSV_COLUMNS = ("brief", "seed", "draw", "spread", "file", "valid", "coverage", "objective", "time",
               "rooms", "termination", "error")
#: Files in an input folder that are outputs, not briefs.
NOT_BRIEFS = (".layout.json", ".expanded.json")


class BatchUsageError(Exception):
    """Arguments the command refuses before laying anything out."""


def add_batch(commands: Any) -> None:
    p = commands.add_parser(
        "batch",
        help="lay out briefs many times each, on every core (a warm process pool)",
        description="Lay out each brief COUNT times with seeds SEED, SEED+1, ... (each "
        "seed its own arrangement: options.diverse), writing one file per layout, "
        "summary.json and summary.csv to DIR. Rerunning skips the layouts already done.",
        epilog=f"exit codes: {EXIT_OK} every layout done, {EXIT_NO_LAYOUT} some failed "
        f"(see the summary), 2 invalid input, {EXIT_INTERRUPTED} stopped by Ctrl-C (what "
        "was done is kept)",
    )
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="a brief (problem JSON, templated or not) or a folder of them")
    p.add_argument("-n", "--count", type=_positive, required=True, metavar="N",
                   help="layouts per brief")
    p.add_argument("-o", "--out", required=True, metavar="DIR",
                   help="folder for the layouts and the summary (made if missing)")
    p.add_argument("--processes", type=_positive, default=os.cpu_count() or 1, metavar="P",
                   help="worker processes (default: every core)")
    p.add_argument("--seed", type=int, default=0, metavar="S",
                   help="the first layout's seed (default 0)")
    p.add_argument("--format", choices=FORMAT_NAMES, default="json",
                   help="what each layout's file holds (default json)")
    p.add_argument("--time-limit", type=float, metavar="S",
                   help="seconds per layout (default: the brief's options.time_limit, else "
                   "0.4 s per room, at least 1 s)")
    p.add_argument("--vary", choices=["program", "sizes"], action="append", default=[],
                   help="'program': draw room counts and sizes from a templated brief's "
                   "template, per seed; 'sizes': accepted, changes nothing (every batch "
                   "draws the sizes it aims at within the rooms' bounds) (repeatable)")
    p.add_argument("--tolerance", type=float, default=None, metavar="T",
                   help="stop each solve at its first good layout (valid, covering 99 %%) "
                   "(the default), or with T, once a brief has 4 good layouts, at its first "
                   "good layout whose Eq. 12 is within T (relative) of the brief's best so far")
    p.add_argument("--distinct", action="store_true", default=True,
                   help="lay a good layout out again, under another draw, when the batch "
                   "already holds its plan (--draws times at most; the first new plan is "
                   "kept, else the first layout): the default")
    p.add_argument("--no-distinct", dest="distinct", action="store_false",
                   help="keep a layout whose plan the batch holds (its walls moved apart "
                   "where they could be): fewer solves, fewer distinct plans")
    p.add_argument("--draws", type=_positive, default=None, metavar="K",
                   help="the draws a layout may have beyond its first (default 2)")
    p.add_argument("--no-spread", dest="spread", action="store_false",
                   help="keep a good layout as its solve gave it when the batch already "
                   "holds its plan (by default its walls are moved apart from the plans "
                   "near it: solver/pipeline/spread.py)")
    p.add_argument("--full", action="store_true",
                   help="never stop a solve early: each layout gets its whole time limit")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(func=cmd_batch)


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"at least 1, got {value}")
    return value


def find_briefs(inputs: list[str]) -> list[Path]:
    """The brief files named, folders replaced by their ``*.json`` briefs."""
    briefs: list[Path] = []
    for item in inputs:
        path = Path(item)
        if path.is_dir():
            found = sorted(p for p in path.glob("*.json") if not p.name.endswith(NOT_BRIEFS))
            if not found:
                raise BatchUsageError(f"{item}: no *.json briefs in this folder")
            briefs += found
        elif path.is_file():
            briefs.append(path)
        else:
            raise BatchUsageError(f"{item}: no such file or folder")
    names = [b.stem for b in briefs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise BatchUsageError(f"two briefs named {', '.join(twice)}: their layouts would "
                              "share file names")
    return briefs


def load_brief(path: Path) -> dict[str, Any]:
    """The brief's JSON, checked to be a valid problem (templates expanded)."""
    from pydantic import ValidationError

    from floorplan.models import Problem
    from floorplan.service.cli.solve import format_validation_error

    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise BatchUsageError(f"{path}: cannot read a brief: {err}") from None
    try:
        Problem.model_validate(data)
    except ValidationError as err:
        raise BatchUsageError(f"{path}: invalid problem\n{format_validation_error(err)}") from None
    return data


def cmd_batch(args: argparse.Namespace, interrupted: Callable[[], bool]) -> int:
    from floorplan.service.cli.solve import UsageError

    try:
        briefs = {p.stem: load_brief(p) for p in find_briefs(args.inputs)}
    except BatchUsageError as err:
        raise UsageError(str(err)) from None
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UsageError(f"{out}: cannot make the folder: {err}") from None
    if args.time_limit is not None and not 0 < args.time_limit <= 86400:
        raise UsageError("--time-limit: between 0 and 86400 seconds")
    if args.tolerance is not None and args.tolerance < 0:
        raise UsageError("--tolerance: 0 or more")
    if args.draws is not None and not args.distinct:
        raise UsageError("--draws: not with --no-distinct")
    return run_batch(args, briefs, out, interrupted)


def run_batch(args: argparse.Namespace, briefs: dict[str, dict[str, Any]], out: Path,
              interrupted: Callable[[], bool]) -> int:
    from floorplan.models import Layout, Problem
    from floorplan.service.batch import (
        DEFAULT_TOLERANCE,
        DISTINCT_DRAWS,
        BestSoFar,
        LayoutRow,
        LayoutTask,
        SpreadTask,
        Tally,
        batch_time_limit,
        hard_limit,
        lay_out_to_file,
        spread_to_file,
    )
    from floorplan.service.cli.pool import WarmPool
    from floorplan.solver.distinct import NEAR_SHARE

    extension = next(f.extension for f in FORMATS if f.name == args.format)
    tally = Tally()
    done = _journal(out, tally)
    tolerance = None if args.full else (
        DEFAULT_TOLERANCE if args.tolerance is None else args.tolerance)
    best = BestSoFar(tolerance)
    for row in tally.rows:
        best.add(row)

    def spread_path(tried: Path) -> Path:
        """Where a try's layout with its walls moved is written until it is kept."""
        return tried.with_name(f".{tried.stem.lstrip('.')}.spread{tried.suffix}")

    def draw_path(name: str, seed: int, draw: int = 0) -> Path:
        """A layout's file; a draw's own until it is kept (a hidden name)."""
        final = out / f"{name}-{seed:06d}.{extension}"
        return final if draw == 0 else final.with_name(f".{final.stem}.draw{draw}.{extension}")

    todo = [(name, seed) for name in briefs
            for seed in range(args.seed, args.seed + args.count)
            if (name, seed) not in done or not draw_path(name, seed).exists()]
    limits = {name: args.time_limit or Problem.model_validate(brief).options.time_limit
              or batch_time_limit(Problem.model_validate(brief)) for name, brief in briefs.items()}
    total = len(briefs) * args.count
    skipped = total - len(todo)

    # Layouts waiting for a new plan (their walls moved apart, or --distinct's draws): the
    # first layout, kept in its file until a new plan replaces it, and its row; the
    # tasks to hand out before new layouts, and the layouts running.
    held: dict[tuple[str, int], tuple[LayoutRow, Layout, dict[str, Any]]] = {}
    queued_first: deque[tuple[tuple[str, int, int, bool], Any, Any]] = deque()
    running: set[tuple[str, int]] = set()

    def task_of(name: str, seed: int, draw: int = 0) -> LayoutTask:
        return LayoutTask(briefs[name], seed, args.time_limit, "program" in args.vary,
                          vary_sizes="sizes" in args.vary,
                          good_enough=best.good_enough(name), draw=draw)

    def solve_task(name: str, task: LayoutTask) -> tuple[tuple[str, int, int, bool], Any, Any]:
        return ((name, task.seed, task.draw, False), lay_out_to_file,
                (task, str(draw_path(name, task.seed, task.draw)), args.format, name))

    def tasks() -> Iterator[tuple[Any, Any, Any, float] | None]:
        queued = iter(todo)
        while True:
            if queued_first:
                key, function, argument = queued_first.popleft()
            elif (item := next(queued, None)) is not None:
                key, function, argument = solve_task(item[0], task_of(*item))
            elif running:
                yield None  # a layout still running may ask for another step
                continue
            else:
                return
            running.add(key[:2])
            yield key, function, argument, hard_limit(limits[key[0]])

    def settle(row: LayoutRow, layout: Layout | None, entry: dict[str, Any]) -> None:
        """Count a finished layout, journalled with `entry` unless it failed (empty)."""
        nonlocal finished
        if entry:
            journal.write(json.dumps(entry) + "\n")
            journal.flush()
        tally.add(row, layout)
        best.add(row)
        finished += 1
        if bar is not None:
            bar.advance(row)

    def next_try(name: str, seed: int, draw: int) -> None:
        """A layout whose try `draw` gave no new plan: another draw (--distinct), else
        its first layout stands."""
        if args.distinct and draw < (args.draws or DISTINCT_DRAWS):
            tally.redraws += 1
            queued_first.append(solve_task(name, task_of(name, seed, draw + 1)))
        else:
            settle(*held.pop((name, seed)))

    def keep_new(name: str, seed: int, drawn: Path, row: LayoutRow, layout: Layout,
                 layout_json: str) -> None:
        """A try that gave a new plan: it replaces the first layout in the layout's file."""
        final = draw_path(name, seed)
        if drawn != final:
            drawn.replace(final)
        row.file = final.name
        held.pop((name, seed), None)
        settle(row, layout, {"row": row.model_dump(mode="json"),
                             "layout": json.loads(layout_json)})

    started = time.monotonic()
    finished = 0
    bar = None if args.quiet else _Bar(total, skipped)
    journal = (out / JOURNAL).open("a", encoding="utf-8")
    try:
        with WarmPool(min(args.processes, max(len(todo), 1)),
                      warm_up="floorplan.solver.pipeline.dispatch") as pool:
            keep_sigint_blocked()  # the pool's start may have unblocked it (interrupt.py)
            for outcome in pool.results(tasks(), should_stop=interrupted):
                name, seed, draw, spread = outcome.key
                running.discard((name, seed))
                tried = spread_path(draw_path(name, seed, draw)) if spread else draw_path(
                    name, seed, draw)
                if outcome.error is not None or outcome.result is None:
                    # A failed solve, or walls that could not be moved far enough.
                    if draw or spread:
                        tried.unlink(missing_ok=True)
                    if draw == 0 and not spread:
                        settle(LayoutRow(brief=name, seed=seed, error=outcome.error), None, {})
                    else:
                        next_try(name, seed, draw)
                    continue
                row_data, layout_json, *problem_json = outcome.result
                row = LayoutRow.model_validate(row_data)
                layout = Layout.model_validate_json(layout_json)
                if row.good and tally.plans.is_new(layout):
                    keep_new(name, seed, tried, row, layout, layout_json)
                    continue
                if draw == 0 and not spread:
                    entry = {"row": row_data, "layout": json.loads(layout_json)}
                    if not row.good or not (args.spread or args.distinct):
                        settle(row, layout, entry)
                        continue
                    held[name, seed] = (row, layout, entry)
                elif draw or spread:
                    tried.unlink(missing_ok=True)
                if row.good and not spread and args.spread:
                    # The batch holds this plan: move its walls apart from those near it.
                    queued_first.appendleft(((name, seed, draw, True), spread_to_file, SpreadTask(
                        problem_json[0], layout_json, row_data,
                        tally.plans.near(layout, NEAR_SHARE),
                        str(spread_path(draw_path(name, seed, draw))), args.format)))
                else:
                    next_try(name, seed, draw)
            # Stopped while layouts waited for a new plan: their first layouts stand.
            for key in list(held):
                settle(*held.pop(key))
    finally:
        journal.close()
        if bar is not None:
            bar.stop()
        for stray in [*out.glob(f".*.draw*.{extension}"), *out.glob(f".*.spread.{extension}")]:
            stray.unlink(missing_ok=True)
    stopped = interrupted()
    summary = tally.summary(time.monotonic() - started, finished)
    _write_summary(out, summary.model_dump(mode="json"), summary.rows)
    if not args.quiet:
        print(f"{summary.layouts} of {total} layouts ({skipped} done before), "
              f"{summary.valid} valid, {summary.failed} failed; {summary.distinct_plans} "
              f"distinct plans ({summary.spread} with walls moved apart), "
              f"{summary.distinct_graphs} adjacency graphs"
              f"{f' ({summary.redraws} solves redrawn for new plans)' if args.distinct else ''}; "
              f"{summary.rate:.2f} layouts/s; summary in {out / SUMMARY_JSON}",
              file=sys.stderr)
    if stopped:
        print(f"{PROG}: interrupted; {summary.layouts} of {total} layouts kept, rerun the "
              "command to go on", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_NO_LAYOUT if summary.failed else EXIT_OK


def _journal(out: Path, tally: Tally) -> set[tuple[str, int]]:
    """The layouts the journal lists (read into `tally`); a torn last line is ignored."""
    from floorplan.models import Layout
    from floorplan.service.batch import LayoutRow

    done: set[tuple[str, int]] = set()
    path = out / JOURNAL
    if not path.exists():
        return done
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            entry = json.loads(line)
            row = LayoutRow.model_validate(entry["row"])
            layout = Layout.model_validate(entry["layout"])
        except (ValueError, KeyError):
            continue
        if (row.brief, row.seed) in done or not (out / (row.file or "")).is_file():
            continue
        done.add((row.brief, row.seed))
        tally.add(row, layout)
    return done


def _write_summary(out: Path, summary: dict[str, Any], rows: list[LayoutRow]) -> None:
    (out / SUMMARY_JSON).write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    with (out / SUMMARY_CSV).open("w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(CSV_COLUMNS)
        for row in rows:
            data = row.model_dump()
            writer.writerow(["" if data[c] is None else data[c] for c in CSV_COLUMNS])


class _Bar:
    """The rich progress bar on stderr: done, failed, rate, time left."""

    def __init__(self, total: int, skipped: int) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self._progress = Progress(
            TextColumn("layouts"), BarColumn(), MofNCompleteColumn(),
            TextColumn("failed {task.fields[failed]}"), TextColumn("{task.fields[rate]}/s"),
            TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(),
            console=Console(file=sys.stderr), transient=False)
        self._task = self._progress.add_task("batch", total=total, completed=skipped,
                                             failed=0, rate="0.00")
        self._failed = 0
        self._done = 0
        self._started = time.monotonic()
        self._progress.start()

    def advance(self, row: LayoutRow) -> None:
        self._done += 1
        self._failed += row.error is not None
        rate = self._done / max(time.monotonic() - self._started, 1e-9)
        self._progress.update(self._task, advance=1, failed=self._failed, rate=f"{rate:.2f}")

    def stop(self) -> None:
        self._progress.stop()
