"""`floorplan submit`: send a problem to a floorplan service, follow the job, write its
layout.

    floorplan submit PROBLEM.json [--server URL] [--api-key KEY] [--wait]
                     [-o LAYOUT.json] [--format json|svg|dxf|geojson|ifc] [--svg PLAN.svg]
                     [--storey-height M] [--dxf-layers ncs|room-type]
                     [--time-limit S] [--seed K] [--quiet]

Without ``--wait`` (or ``-o``/``--svg``, which imply it) the job's id goes to stdout
and the command returns at once. With it, progress goes to stderr (status, level,
sub-domain, incumbent objective, elapsed time: a live line on a terminal with rich
installed, else one line per event), then the layout JSON to ``-o`` (stdout when
omitted; by its extension, or ``--format``, an SVG plan, a DXF drawing, GeoJSON or an
IFC building model, as the service renders them) and the plan to ``--svg``. Ctrl-C
cancels the job and still writes the best layout found so far; a second Ctrl-C aborts
at once. Exit codes are `EXIT_*` below, the same as ``floorplan solve``'s.

The `floorplan` command (``service/cli.py``) adds this subcommand with `add_submit`
when this package is installed. That command also runs ``floorplan solve``, which must
not load numpy before it has set up its Ctrl-C handling: keep this module's top-level
imports to the standard library and `models.formats` (the formats -o can hold, itself
standard library only; the `models` package loads its other modules on first use).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, TextIO

from floorplan_client.models.formats import (
    DEFAULT_STOREY_HEIGHT,
    DXF_LAYERS,
    FORMAT_NAMES,
    format_of,
    in_words,
    storey_height_of,
)

if TYPE_CHECKING:
    from rich.console import Console

    from floorplan_client import Event, Job
    from floorplan_client.models import Layout

EXIT_OK = 0
"""A layout was written (after a Ctrl-C too: ``report.termination`` is then
``interrupted``), or, without ``--wait``, the job was queued."""
EXIT_FAILURE = 1
"""The service could not be reached or failed, or the output could not be written."""
EXIT_INVALID = 2
"""Bad arguments, an unreadable problem file, or a problem the service refused."""
EXIT_NO_LAYOUT = 3
"""The job ended without a layout: infeasible, or nothing found in the time limit."""
EXIT_INTERRUPTED = 130
"""Ctrl-C before the job had a layout, or a second Ctrl-C."""

PROG = "floorplan"
#: Stands for stdin / stdout in file arguments.
STDIO = "-"
#: What -o can hold: the layout JSON, or the service's SVG, DXF or GeoJSON rendering.
FORMATS = FORMAT_NAMES
#: Seconds to wait for a job to end once Ctrl-C has canceled it.
CANCEL_WAIT = 30.0
#: Least seconds between two plain progress lines (status changes always print).
PLAIN_INTERVAL = 0.5


class UsageError(Exception):
    """Input refused before anything is sent; the message is shown as is."""


def add_submit(commands: Any) -> None:
    """Add ``submit`` to the `floorplan` command's subparsers (a `CommandAdder`)."""
    p = commands.add_parser(
        "submit",
        help="send a problem to a floorplan service and follow the job",
        description="Queue PROBLEM on a floorplan service; with --wait follow it live and "
        "write its layout. Ctrl-C cancels the job and writes the best layout so far.",
        epilog=f"exit codes: {EXIT_OK} layout written (or job queued, without --wait), "
        f"{EXIT_INVALID} invalid input, {EXIT_NO_LAYOUT} no layout (infeasible or none in "
        f"time), {EXIT_INTERRUPTED} interrupted before a layout existed, {EXIT_FAILURE} "
        "service unreachable or failed, or output not writable",
    )
    p.add_argument("problem", metavar="PROBLEM.json", help=f"problem file, '{STDIO}' for stdin")
    p.add_argument("--server", metavar="URL",
                   help="the service (default: $FLOORPLAN_URL, else http://127.0.0.1:8000)")
    p.add_argument("--api-key", metavar="KEY",
                   help="API key, if the service wants one (default: $FLOORPLAN_API_KEY)")
    p.add_argument("--wait", action="store_true",
                   help="follow the job until it ends and write its layout "
                   "(implied by -o and --svg)")
    p.add_argument("-o", "--output", metavar="LAYOUT.json",
                   help=f"where to write the layout JSON (default and '{STDIO}': stdout)")
    p.add_argument("--format", choices=list(FORMATS),
                   help=f"what -o holds (default: from its extension, else json): {in_words()}")
    p.add_argument("--storey-height", type=_storey_height, metavar="M",
                   default=DEFAULT_STOREY_HEIGHT,
                   help="ifc: metres from one storey's floor to the next (default "
                   f"{DEFAULT_STOREY_HEIGHT:g}; also the DXF storeys' elevations)")
    p.add_argument("--dxf-layers", choices=DXF_LAYERS, default="ncs",
                   help="dxf: 'ncs' the AIA / US National CAD Standard layers (A-WALL, "
                   "A-AREA, ...; default), 'room-type' the older layer per room type")
    p.add_argument("--svg", metavar="PLAN.svg", help="also write the plan as SVG here")
    p.add_argument("--time-limit", type=float, metavar="S",
                   help="seconds for the solve (overrides options.time_limit)")
    p.add_argument("--seed", type=int, metavar="K", help="random seed (overrides options.seed)")
    p.add_argument("--count", type=int, metavar="N",
                   help="a batch (issue 23): N layouts of the problem, seeds --seed (default "
                   "0), +1, ..., each its own plan; prints the batch's id; with --wait "
                   "follows it, and with --out writes its layouts")
    p.add_argument("--vary", choices=["program"],
                   help="with --count: draw room counts and sizes from a templated brief")
    p.add_argument("--out", metavar="DIR",
                   help="with --count: write each layout as DIR/NAME-SEED.json (implies --wait)")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress or summary on stderr; warnings and errors only")
    # Ctrl-C is ours: it cancels the job (the solver's Ctrl-C handling is for local solves).
    p.set_defaults(func=cmd_submit, own_signals=True)


def _submit_failed(problem: str, err: Exception) -> int:
    """Report a submission the service refused or could not take; the exit code."""
    from floorplan_client import InvalidProblem

    if isinstance(err, InvalidProblem):
        lines = "\n".join(f"  {e}" for e in err.errors) or f"  {err.problem.detail}"
        print(f"{PROG}: error: {problem}: the service refused the problem\n{lines}",
              file=sys.stderr)
        return EXIT_INVALID
    print(f"{PROG}: error: {err}", file=sys.stderr)
    return EXIT_FAILURE


def cmd_submit(args: argparse.Namespace) -> int:
    """Run ``floorplan submit``; returns the exit code."""
    try:
        return _submit(args)
    except UsageError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return EXIT_INVALID
    except KeyboardInterrupt:
        print(f"{PROG}: aborted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _submit(args: argparse.Namespace) -> int:
    from floorplan_client import NOT_GIVEN, Client, FloorplanError

    if args.count is not None:
        return _submit_batch(args)
    if args.out is not None or args.vary is not None:
        raise UsageError("--out and --vary go with --count")
    problem = load_problem(args.problem)
    options = problem.setdefault("options", {}) if isinstance(problem, dict) else None
    for name in ("time_limit", "seed"):
        value = getattr(args, name)
        if value is not None:
            if not isinstance(options, dict):
                raise UsageError(f"{args.problem}: not a problem (a JSON object with options)")
            options[name] = value
    follow = args.wait or args.output is not None or args.svg is not None
    for target in (args.output, args.svg):
        _check_writable(target)

    say = _Say(sys.stderr, quiet=args.quiet)
    api_key = NOT_GIVEN if args.api_key is None else args.api_key
    with Client(args.server, api_key=api_key) as fp:
        try:
            job = fp.submit(problem)
        except FloorplanError as err:
            return _submit_failed(args.problem, err)
        if not follow:
            print(job.id, flush=True)
            say(f"{PROG}: queued job {job.id} on {fp.base_url}")
            return EXIT_OK
        say(f"{PROG}: job {job.id} queued on {fp.base_url} (Ctrl-C cancels it)")
        try:
            return _follow(job, args, say)
        except FloorplanError as err:
            print(f"{PROG}: error: job {job.id}: {err}", file=sys.stderr)
            return EXIT_FAILURE


def _follow(job: Job, args: argparse.Namespace, say: _Say) -> int:
    from floorplan_client import (
        Infeasible,
        JobCanceled,
        JobFailed,
        JobStatus,
        NoResultYet,
        WaitTimeout,
    )

    interrupted = False
    display = make_display(quiet=args.quiet)
    try:
        try:
            for event in job.events():
                display.update(event)
        finally:
            display.close()
    except KeyboardInterrupt:
        interrupted = True
        print(f"{PROG}: canceling job {job.id}; the best layout so far will be written "
              "(Ctrl-C again to abort)", file=sys.stderr, flush=True)
        job.cancel()
    try:
        layout = job.wait(timeout=CANCEL_WAIT)
    except WaitTimeout:
        print(f"{PROG}: error: job {job.id} is still {job.status.value} "
              f"{CANCEL_WAIT:g} s after its cancel", file=sys.stderr)
        return EXIT_FAILURE
    except JobCanceled:
        try:
            layout = job.result()
        except NoResultYet:
            print(f"{PROG}: job {job.id} canceled before any layout was found",
                  file=sys.stderr)
            return EXIT_INTERRUPTED if interrupted else EXIT_NO_LAYOUT
    except JobFailed as err:
        if not isinstance(err, Infeasible) and err.code != "no_solution":
            print(f"{PROG}: error: job {job.id} failed ({err.code}): {err.message}",
                  file=sys.stderr)
            return EXIT_FAILURE
        try:  # the report of a layout without rooms says why, as `floorplan solve` writes it
            report = job.result()
        except NoResultYet:
            report = None
        if report is not None and not _write_outputs(job, report, args, svg=False):
            return EXIT_FAILURE
        print(no_layout_message(err), file=sys.stderr)
        return EXIT_NO_LAYOUT
    if not _write_outputs(job, layout, args, svg=True):
        return EXIT_FAILURE
    say(summary_line(job, layout))
    if not layout.report.valid:
        failed = [c for c in layout.report.constraints if not c.satisfied]
        print(f"{PROG}: warning: the layout fails {len(failed)} check(s): "
              + "; ".join(f"{c.kind} {', '.join(c.rooms)}".strip() for c in failed),
              file=sys.stderr)
    if job.status is JobStatus.CANCELED:
        say(f"{PROG}: job {job.id} canceled; wrote the best layout found so far")
    return EXIT_OK


# -- input and output -------------------------------------------------------------------


def _storey_height(text: str) -> float:
    try:
        return storey_height_of(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def load_problem(source: str) -> Any:
    """The problem file's JSON (stdin for ``-``); `UsageError` says what is wrong."""
    from floorplan_client import ProblemFileError
    from floorplan_client._core import read_problem_file

    if source != STDIO:
        try:
            return read_problem_file(Path(source))
        except ProblemFileError as err:
            raise UsageError(str(err)) from None
    try:
        return json.loads(sys.stdin.read())
    except json.JSONDecodeError as err:
        raise UsageError(f"<stdin>: invalid JSON at line {err.lineno}, column {err.colno}: "
                         f"{err.msg}") from None


def _check_writable(target: str | None) -> None:
    """Refuse before submitting rather than lose the layout afterwards."""
    if target is None or target == STDIO:
        return
    parent = Path(target).resolve().parent
    if not parent.is_dir():
        raise UsageError(f"{target}: directory {parent} does not exist")
    if Path(target).is_dir():
        raise UsageError(f"{target}: is a directory")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"{target}: directory {parent} is not writable")


def _write_outputs(job: Job, layout: Layout, args: argparse.Namespace, *, svg: bool) -> bool:
    """Write the layout (in -o's format) and, when asked and `svg`, the plan; False
    after a failure."""
    ok = True
    target = args.output or STDIO
    fmt = args.format or format_of(target)
    try:
        text = layout.model_dump_json(indent=2) + "\n" if fmt == "json" \
            else job.result(format=fmt, storey_height=args.storey_height,
                            dxf_layers=args.dxf_layers)
        _write_text(target, text)
    except OSError as err:
        print(f"{PROG}: error: cannot write {target}: {err}", file=sys.stderr)
        ok = False
    if svg and args.svg:
        try:
            _write_text(args.svg, job.result(format="svg"))
        except OSError as err:
            print(f"{PROG}: error: cannot write {args.svg}: {err}", file=sys.stderr)
            ok = False
    return ok


def _write_text(target: str, text: str) -> None:
    if target == STDIO:
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    # Write then rename, so that a reader never sees half a file.
    path = Path(target)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


# -- messages and the progress display --------------------------------------------------


class _Say:
    """Prints a line to stderr unless quiet."""

    def __init__(self, stream: TextIO, *, quiet: bool) -> None:
        self.stream = stream
        self.quiet = quiet

    def __call__(self, text: str) -> None:
        if not self.quiet:
            print(text, file=self.stream, flush=True)


def summary_line(job: Job, layout: Layout) -> str:
    """E.g. ``2 rooms  coverage 100.0%  termination optimal  valid yes  job 1f0c...``."""
    r = layout.report
    return (f"{len(layout.all_rooms)} rooms  coverage {r.coverage:.1%}  "
            f"termination {r.termination.value}  valid {'yes' if r.valid else 'no'}  "
            f"job {job.id}")


def no_layout_message(err: Any) -> str:
    """Why a job ended without a layout, with the findings, one per line."""
    lines = [f"{PROG}: no layout ({err.code}): {err.message}"]
    conflict = err.job.error.conflict if err.job.error else None
    if conflict is not None:
        lines += [f"  {conflict.explanation}", "  constraints in conflict:",
                  *(f"    - {c.path}: {c.constraint}" for c in conflict.constraints)]
    findings = list(err.job.error.findings) if err.job.error else []
    if findings:
        lines += ["  findings:", *(f"    - {f}" for f in findings)]
    return "\n".join(lines)


class JobState:
    """What the display shows, from the events seen so far."""

    def __init__(self) -> None:
        self.status = "queued"
        self.level: int | None = None
        self.subdomain: int | None = None
        self.subdomains: int | None = None
        self.objective: float | None = None

    def update(self, event: Event) -> None:
        """Take in one event."""
        from floorplan_client.types import IncumbentEvent, StatusEvent

        if isinstance(event, StatusEvent):
            self.status = event.status.value
            return
        progress = event.progress
        if progress.level is not None:
            self.level = progress.level
            self.subdomain, self.subdomains = progress.subdomain, progress.subdomains
        if isinstance(event, IncumbentEvent):
            objective = progress.objective if progress.objective is not None \
                else event.layout.report.objective
            if objective is not None:
                self.objective = objective
        elif progress.objective is not None:
            self.objective = progress.objective

    def where(self) -> str:
        """E.g. ``running  level 2 sub 1/3``."""
        text = self.status
        if self.level is not None:
            text += f"  level {self.level}"
            if self.subdomains:
                text += f" sub {self.subdomain}/{self.subdomains}"
        return text

    def objective_text(self) -> str:
        """E.g. ``objective 12.41``; "" before the first incumbent."""
        from floorplan_client.models.jobs import format_number

        return "" if self.objective is None else f"objective {format_number(self.objective)}"


class Display(Protocol):
    """Shows a job's progress while it runs."""

    def update(self, event: Event) -> None:
        """Take in one event."""

    def close(self) -> None:
        """The job has ended (or the wait was cut short): stop showing."""


class NullDisplay:
    """Shows nothing (``--quiet``)."""

    def update(self, event: Event) -> None:
        """Ignore the event."""

    def close(self) -> None:
        """Nothing to stop."""


class PlainDisplay:
    """One line per event on a stream: every status, progress at most every
    `PLAIN_INTERVAL` seconds. For logs, and where rich is not installed."""

    def __init__(self, stream: TextIO, interval: float = PLAIN_INTERVAL,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream
        self.interval = interval
        self.clock = clock
        self.state = JobState()
        self._started = clock()
        self._last = -math.inf

    def update(self, event: Event) -> None:
        """Take in one event; print a line unless one was printed moments ago."""
        self.state.update(event)
        now = self.clock()
        if event.kind != "status" and now - self._last < self.interval:
            return
        self._last = now
        parts = [f"[{now - self._started:6.1f}s] {self.state.where()}",
                 self.state.objective_text()]
        print("  ".join(p for p in parts if p), file=self.stream, flush=True)

    def close(self) -> None:
        """Nothing to stop."""


class RichDisplay:
    """A live line on a terminal: spinner, status, level, sub-domain, incumbent
    objective and elapsed time (rich's progress display)."""

    def __init__(self, console: Console | None = None) -> None:
        from rich.console import Console
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        self.state = JobState()
        self._progress = Progress(
            SpinnerColumn(), TextColumn("{task.description}"),
            TextColumn("{task.fields[objective]}"), TimeElapsedColumn(),
            console=console or Console(stderr=True), transient=False,
        )
        self._task = self._progress.add_task(self.state.where(), total=None, objective="")
        self._progress.start()

    def update(self, event: Event) -> None:
        """Take in one event and redraw."""
        self.state.update(event)
        self._progress.update(self._task, description=self.state.where(),
                              objective=self.state.objective_text())

    def close(self) -> None:
        """Stop the live line, leaving its last state on the screen."""
        self._progress.stop()


def make_display(*, quiet: bool, stream: TextIO | None = None) -> Display:
    """Rich's live line on a terminal when rich is installed, plain lines otherwise,
    nothing when quiet."""
    stream = stream or sys.stderr
    if quiet:
        return NullDisplay()
    if stream.isatty():
        try:
            return RichDisplay()
        except ImportError:
            pass
    return PlainDisplay(stream)


#: Seconds between two looks at a batch's progress while following it.
BATCH_POLL = 1.0


def _submit_batch(args: argparse.Namespace) -> int:
    """``floorplan submit --count N``: queue a batch, and with --wait or --out follow it
    (a progress line per change) and write its layouts."""
    import time
    from pathlib import Path

    from floorplan_client import NOT_GIVEN, Client, FloorplanError

    if args.count < 1:
        raise UsageError("--count: at least 1")
    if args.output is not None or args.svg is not None:
        raise UsageError("a batch writes to --out DIR, not -o or --svg")
    problem = load_problem(args.problem)
    say = _Say(sys.stderr, quiet=args.quiet)
    api_key = NOT_GIVEN if args.api_key is None else args.api_key
    with Client(args.server, api_key=api_key) as fp:
        try:
            batch = fp.submit_batch(problem, args.count, seed=args.seed or 0,
                                    time_limit=args.time_limit,
                                    vary_program=args.vary == "program")
        except FloorplanError as err:
            return _submit_failed(args.problem, err)
        print(batch.id, flush=True)
        say(f"{PROG}: batch {batch.id} of {batch.count} layouts queued on {fp.base_url}")
        if not (args.wait or args.out):
            return EXIT_OK
        try:
            shown = None
            while not batch.status.terminal:
                time.sleep(BATCH_POLL)
                batch = fp.get_batch(batch.id)
                line = (f"{batch.succeeded + batch.failed + batch.canceled}/{batch.count} done, "
                        f"{batch.running} running, {batch.failed} failed")
                if line != shown:
                    say(f"{PROG}: {line}")
                    shown = line
            batch = fp.get_batch(batch.id, summary=True)
            say(f"{PROG}: batch {batch.status.value}: {batch.valid} valid, "
                f"{batch.distinct_plans} distinct plans, {batch.distinct_graphs} adjacency "
                "graphs")
            if args.out:
                out = Path(args.out)
                out.mkdir(parents=True, exist_ok=True)
                for line in fp.batch_results(batch.id):
                    if line.layout is not None:
                        target = out / f"{batch.name}-{line.seed:06d}.json"
                        target.write_text(line.layout.model_dump_json(indent=2) + "\n",
                                          encoding="utf-8")
        except FloorplanError as err:
            print(f"{PROG}: error: batch {batch.id}: {err}", file=sys.stderr)
            return EXIT_FAILURE
        except KeyboardInterrupt:
            fp.cancel_batch(batch.id)
            print(f"{PROG}: canceled the rest of batch {batch.id}", file=sys.stderr)
            return EXIT_INTERRUPTED
    return EXIT_OK if batch.failed == 0 else EXIT_NO_LAYOUT
