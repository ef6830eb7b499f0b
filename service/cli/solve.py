"""The `floorplan` command line: solve a problem file from the shell.

    floorplan solve PROBLEM.json -o LAYOUT.json [--svg PLAN.svg] [--time-limit S]
                    [--seed K] [--max-levels N] [--processes N] [--quiet] [--expand]

Progress goes to stderr (one line per solver event, new incumbents at most a few
times a second), then a one-line summary; the layout JSON goes to ``-o`` (stdout when
``-o`` is ``-`` or omitted). Exit codes are the module constants ``EXIT_*`` below.

Ctrl-C stops the solve gracefully: the best layout found so far is written (exit 0,
``report.termination`` "interrupted"; 130 when there was none yet). A second Ctrl-C
aborts at once with 130 (see `sigint_flag` for how the
signal is kept from SCIP). For that, this module imports the solver (and with it numpy,
which starts native threads) only once SIGINT is blocked: keep its top-level imports
to the standard library.

The parser is built from subcommands so that ``serve`` and ``submit`` can join ``solve``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, suppress
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, Literal, TextIO

if TYPE_CHECKING:
    from pydantic import ValidationError

    from models import Layout, Problem
    from solver.events import SolveEvent

EXIT_OK = 0
"""A layout with rooms was written (it may still fail checks: see the warning; a
Ctrl-C may have cut the solve short: see ``report.termination``)."""
EXIT_FAILURE = 1
"""The output could not be written."""
EXIT_INVALID = 2
"""Bad arguments or an invalid problem; nothing was solved."""
EXIT_NO_LAYOUT = 3
"""No layout: infeasible, or no solution within the time limit. The JSON report says why."""
EXIT_INTERRUPTED = 130
"""Stopped by Ctrl-C before there was a layout, or aborted by a second one
(128 + SIGINT, the shell's convention)."""

#: Least seconds between two printed INCUMBENT events (other events are always printed).
INCUMBENT_INTERVAL = 0.25
#: Bounds at or beyond this magnitude are SCIP's infinity and printed as such.
SCIP_INFINITY = 1e19
#: `solver.events.Phase.INCUMBENT` (a StrEnum), spelt out to keep the solver import lazy.
INCUMBENT = "incumbent"
#: Objects up to this many characters (with their indent) stay on one line in --expand.
READABLE_WIDTH = 88
#: Stands for "stdin" / "stdout" in file arguments.
STDIO = "-"

PROG = "floorplan"


class UsageError(Exception):
    """Input the command refuses before solving; the message is shown as is."""


# -- the parser -------------------------------------------------------------------------


#: Adds a subcommand to the parser's subparsers; the service adds `serve` this way, so
#: the solver's command line knows nothing of HTTP.
CommandAdder = Callable[[Any], None]


def build_parser(extra: Sequence[CommandAdder] = ()) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Interior layouts from building outlines and room constraints "
        "(MIQP on SCIP, after Wu et al.).",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_solve(commands)
    for add in extra:
        add(commands)
    return parser


def _add_solve(commands: Any) -> None:
    p = commands.add_parser(
        "solve",
        help="lay out a problem file locally",
        description="Solve PROBLEM (the JSON contract of DESIGN.md) and write the layout.",
        epilog=f"exit codes: {EXIT_OK} layout written, {EXIT_INVALID} invalid input, "
        f"{EXIT_NO_LAYOUT} no layout (the JSON report says why), "
        f"{EXIT_INTERRUPTED} interrupted before a layout was found (Ctrl-C once stops "
        "the solve and writes the best layout so far; twice aborts), "
        f"{EXIT_FAILURE} output not writable",
    )
    p.add_argument("problem", metavar="PROBLEM.json", help=f"problem file, '{STDIO}' for stdin")
    p.add_argument("-o", "--output", metavar="LAYOUT.json", default=STDIO,
                   help=f"where to write the layout JSON (default and '{STDIO}': stdout)")
    p.add_argument("--svg", metavar="PLAN.svg", help="also draw the layout as SVG here")
    p.add_argument("--format", choices=["json", "svg", "dxf", "geojson"],
                   help="what -o holds (default: from its extension, else json): the layout "
                   "JSON, an SVG plan, a DXF drawing in metres, or GeoJSON in the local frame")
    p.add_argument("--time-limit", type=float, metavar="S",
                   help="seconds for the whole solve (overrides options.time_limit)")
    p.add_argument("--seed", type=int, metavar="K", help="random seed (overrides options.seed)")
    p.add_argument("--max-levels", type=int, metavar="N",
                   help="deepest hierarchy level (overrides options.max_levels)")
    p.add_argument("--processes", type=_process_count, default=1, metavar="N",
                   help="processes for this solve (default 1). With 2 or more, a second "
                   "level-1 search runs under another seed and the better start goes on, "
                   "and the independent sub-domains of each refinement level are solved "
                   "at once")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress or summary on stderr; warnings and errors only")
    p.add_argument("--expand", action="store_true",
                   help="write the problem as it would be solved (a template expanded into "
                   "sizes, adjacencies and exterior walls, options overridden) to -o "
                   "instead of solving; edit it and solve that file")
    p.set_defaults(func=cmd_solve)


def _process_count(text: str) -> int:
    try:
        count = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if count < 1:
        raise argparse.ArgumentTypeError(f"at least 1, got {count}")
    return count


def main(argv: list[str] | None = None, extra: Sequence[CommandAdder] = ()) -> int:
    """Entry point of the `floorplan` console script; returns the exit code."""
    parser = build_parser(extra)
    args = parser.parse_args(argv)  # exits with 2 on a usage error, as argparse does
    if getattr(args, "own_signals", False):
        return int(args.func(args))  # a server handles its own SIGINT and SIGTERM
    try:
        # Before the command imports the solver: see `sigint_flag`.
        with sigint_flag() as interrupted:
            return args.func(args, interrupted)
    except UsageError as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return EXIT_INVALID
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


# -- solve ------------------------------------------------------------------------------


def cmd_solve(args: argparse.Namespace, interrupted: Callable[[], bool]) -> int:
    problem = load_problem(args.problem)
    problem = with_overrides(problem, time_limit=args.time_limit, seed=args.seed,
                             max_levels=args.max_levels)
    if args.expand:
        return write_expanded(args, problem)

    from models import Termination
    from solver import solve
    from solver.pipeline.pool import end_pool, subdomain_pool
    from solver.pipeline.subdomains import SubdomainExecutor

    for target in (args.output, args.svg):
        _check_writable(target)
    progress = None if args.quiet else ProgressPrinter(sys.stderr)
    # The pool's processes ignore Ctrl-C; a second one, which ends this process at once,
    # leaves the pool to end itself (solver.pipeline.pool.pool_process_init).
    pool = subdomain_pool(args.processes)
    if pool is not None:
        keep_sigint_blocked()
    try:
        layout = solve(problem, on_event=progress, should_stop=interrupted,
                       subdomains=None if pool is None else SubdomainExecutor(pool,
                                                                              args.processes))
    finally:
        end_pool(pool)
    stopped = interrupted() or layout.report.termination is Termination.INTERRUPTED
    written = _write_outputs(args, problem, layout)
    if not args.quiet:
        print(summary_line(layout), file=sys.stderr)
    if not written:
        return EXIT_FAILURE
    if not layout.all_rooms:
        print(no_layout_message(layout), file=sys.stderr)
    elif not layout.report.valid:
        print(invalid_layout_warning(layout), file=sys.stderr)
    elif layout.report.violations and not args.quiet:
        print(soft_violations_note(layout), file=sys.stderr)
    if stopped:
        what = "the best layout found so far" if layout.all_rooms else "the report"
        print(f"{PROG}: interrupted; wrote {what}", file=sys.stderr)
        return EXIT_OK if layout.all_rooms else EXIT_INTERRUPTED
    return EXIT_OK if layout.all_rooms else EXIT_NO_LAYOUT


def write_expanded(args: argparse.Namespace, problem: Problem) -> int:
    """``--expand``: the validated problem as JSON, only the fields that were given or
    that a template filled in (the defaults stay implicit, as in a hand-written file)."""
    if args.svg or (args.format or _format_of(args.output)) != "json":
        raise UsageError("--expand writes the problem as JSON: drop --svg and --format, "
                         "and give -o a .json name")
    _check_writable(args.output)
    try:
        _write_text(args.output, readable_json(problem.model_dump(mode="json", exclude_unset=True))
                    + "\n")
    except OSError as err:
        print(f"{PROG}: error: cannot write {args.output}: {err}", file=sys.stderr)
        return EXIT_FAILURE
    if not args.quiet:
        adjacencies = len(problem.adjacency) + sum(len(f.adjacency) for f in problem.floors or [])
        print(f"{problem.room_count} rooms, {adjacencies} adjacencies; "
              "not solved (--expand)", file=sys.stderr)
    return EXIT_OK


def readable_json(value: Any, indent: str = "") -> str:
    """JSON for people to edit: an object one field a line unless it fits on one, and a
    list of numbers or of points on one line (``"boundary": [[0, 0], [9, 0], ...]``)."""
    inner = indent + "  "
    flat = json.dumps(value, separators=(", ", ": "))
    if isinstance(value, dict) and value and (
            len(indent) + len(flat) > READABLE_WIDTH
            or any(isinstance(v, dict) for v in value.values())):
        fields = [f"{inner}{json.dumps(k)}: {readable_json(v, inner)}" for k, v in value.items()]
        return "{\n" + ",\n".join(fields) + "\n" + indent + "}"
    if isinstance(value, list) and value and any(isinstance(v, dict) for v in value):
        items = [inner + readable_json(v, inner) for v in value]
        return "[\n" + ",\n".join(items) + "\n" + indent + "]"
    return flat


def load_problem(source: str) -> Problem:
    """Read and validate a problem; raise `UsageError` naming the file, position or field."""
    from pydantic import ValidationError

    from models import Problem

    name = "<stdin>" if source == STDIO else source
    try:
        text = sys.stdin.read() if source == STDIO else Path(source).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UsageError(f"{name}: no such file") from None
    except IsADirectoryError:
        raise UsageError(f"{name}: is a directory, not a problem file") from None
    except UnicodeDecodeError as err:
        raise UsageError(f"{name}: not UTF-8 text (byte {err.start})") from None
    except OSError as err:
        raise UsageError(f"{name}: cannot read: {err.strerror or err}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise UsageError(
            f"{name}: invalid JSON at line {err.lineno}, column {err.colno}: {err.msg}"
        ) from None
    try:
        return Problem.model_validate(data)
    except ValidationError as err:
        raise UsageError(f"{name}: invalid problem\n{format_validation_error(err)}") from None


def format_validation_error(err: ValidationError, prefix: str = "") -> str:
    """One line per error, ``field.path: message``, e.g.
    ``rooms.2.positions.0: position (20.0, 1.0) of room 'bath' is outside the boundary``."""
    lines = []
    for e in err.errors(include_url=False):
        loc = ((prefix,) if prefix else ()) + tuple(e["loc"])
        path = ".".join(str(part) for part in loc)
        lines.append(f"  {path or '(problem)'}: {e['msg']}")
    return "\n".join(lines)


def with_overrides(problem: Problem, **overrides: Any) -> Problem:
    """`problem` with the given options replaced (None means keep), validated again."""
    from pydantic import ValidationError

    from models import Options

    update = {k: v for k, v in overrides.items() if v is not None}
    if not update:
        return problem
    try:
        # Only the fields given, so that --expand shows what was stated, not every default.
        options = Options.model_validate(problem.options.model_dump(exclude_unset=True) | update)
    except ValidationError as err:
        flags = ", ".join(f"--{k.replace('_', '-')}" for k in update)
        raise UsageError(f"invalid option ({flags})\n"
                         f"{format_validation_error(err, 'options')}") from None
    return problem.model_copy(update={"options": options})


def _check_writable(target: str | None) -> None:
    """Refuse before solving rather than lose the result afterwards."""
    if target is None or target == STDIO:
        return
    parent = Path(target).resolve().parent
    if not parent.is_dir():
        raise UsageError(f"{target}: directory {parent} does not exist")
    if Path(target).is_dir():
        raise UsageError(f"{target}: is a directory")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"{target}: directory {parent} is not writable")


def _write_outputs(args: argparse.Namespace, problem: Problem, layout: Layout) -> bool:
    """Write the layout JSON and the SVG; False (with a message) when one failed."""
    from solver.export import render
    from solver.export.svg import render_svg

    ok = True
    fmt = args.format or _format_of(args.output)
    try:
        if fmt == "json":
            _write_text(args.output, layout.model_dump_json(indent=2) + "\n")
        else:
            _write_text(args.output, render(problem, layout, fmt).decode())
    except OSError as err:
        print(f"{PROG}: error: cannot write {args.output}: {err}", file=sys.stderr)
        ok = False
    if args.svg:
        try:
            _write_text(args.svg, render_svg(problem, layout))
        except OSError as err:
            print(f"{PROG}: error: cannot write {args.svg}: {err}", file=sys.stderr)
            ok = False
    return ok


def _format_of(target: str) -> Literal["json", "svg", "dxf", "geojson"]:
    """The output format an -o file name asks for."""
    suffix = Path(target).suffix.lower().lstrip(".")
    if suffix in ("svg", "dxf", "geojson"):
        return suffix  # type: ignore[return-value]
    return "json"


def _write_text(target: str, text: str) -> None:
    if target == STDIO:
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    # Write then rename, so a reader never sees half a file.
    path = Path(target)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


# -- Ctrl-C -----------------------------------------------------------------------------


@contextmanager
def sigint_flag() -> Iterator[Callable[[], bool]]:
    """Within the block the first SIGINT only sets a flag (read it with the yielded
    function, a `should_stop` for `solve`); a second one aborts the process at once.

    SCIP installs its own SIGINT handler while it optimises (misc/catchctrlc): it ends
    the current MIQP only, and a Python handler never hears of the signal, so the solve
    would go on with the next one. Hence SIGINT is blocked in this thread (and in the
    threads it starts) and a watcher thread takes it with ``sigwait``: no handler, ours
    or SCIP's, ever runs. Where ``pthread_sigmask`` is missing a plain handler does.

    Threads started before the block keep SIGINT unblocked and may take it (numpy's
    OpenBLAS starts some on import): enter it before the solver is imported."""
    if threading.current_thread() is not threading.main_thread():
        yield lambda: False  # signals reach the main thread only; leave them alone
        return
    if not hasattr(signal, "pthread_sigmask"):
        with _sigint_handler() as received:
            yield received
        return
    watcher = _SigintWatcher()
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        watcher.start()
        yield watcher.received
    finally:
        watcher.stop()
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def keep_sigint_blocked() -> None:
    """Block SIGINT in this thread again, within `sigint_flag`. Starting a process pool
    starts multiprocessing's resource tracker, which unblocks SIGINT in the calling
    thread once the tracker runs; SCIP's handler or a KeyboardInterrupt would then
    take the next Ctrl-C instead of the watcher."""
    if threading.current_thread() is threading.main_thread() and hasattr(
            signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


class _SigintWatcher:
    """A daemon thread waiting for SIGINT with ``sigwait`` (see `sigint_flag`)."""

    def __init__(self) -> None:
        self._received = False
        self._closing = False
        self._thread = threading.Thread(target=self._watch, name="sigint-watcher", daemon=True)

    def received(self) -> bool:
        return self._received

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._closing = True
        if self._thread.ident is not None and self._thread.is_alive():
            with suppress(OSError):  # it may have just taken a last real SIGINT and ended
                signal.pthread_kill(self._thread.ident, signal.SIGINT)
        self._thread.join()

    def _watch(self) -> None:
        while True:
            signal.sigwait({signal.SIGINT})
            if self._closing:
                return
            if self._received:
                print(f"{PROG}: aborted", file=sys.stderr, flush=True)
                os._exit(EXIT_INTERRUPTED)
            self._received = True
            print(f"{PROG}: stopping; the best layout so far will be written "
                  "(Ctrl-C again to abort)", file=sys.stderr, flush=True)


@contextmanager
def _sigint_handler() -> Iterator[Callable[[], bool]]:
    received = False

    def handler(_signum: int, _frame: FrameType | None) -> None:
        nonlocal received
        if received:
            raise KeyboardInterrupt
        received = True

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield lambda: received
    finally:
        signal.signal(signal.SIGINT, previous)


# -- messages ---------------------------------------------------------------------------


class ProgressPrinter:
    """An `on_event` sink printing one line per event, incumbents throttled.

    An incumbent that came too soon after the last printed one is held back and
    printed before the next other event, so each MIQP's last incumbent shows."""

    def __init__(self, stream: TextIO, interval: float = INCUMBENT_INTERVAL,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream
        self.interval = interval
        self.clock = clock
        self._last_incumbent = -math.inf
        self._held: SolveEvent | None = None

    def __call__(self, event: SolveEvent) -> None:
        if event.phase == INCUMBENT:
            now = self.clock()
            if now - self._last_incumbent < self.interval:
                self._held = event
                return
            self._last_incumbent = now
        elif self._held is not None:
            self._print(self._held)
        self._held = None
        self._print(event)

    def _print(self, event: SolveEvent) -> None:
        print(progress_line(event), file=self.stream, flush=True)


def progress_line(event: SolveEvent) -> str:
    """E.g. ``[  1.23s] level 2 sub 1/3  obj 12.41  bound 3.20  rooms a, b: optimal``."""
    parts = [f"[{event.elapsed:6.2f}s] level {event.level}"]
    if event.subdomains:
        parts[0] += f" sub {event.subdomain}/{event.subdomains}"
    if event.objective is not None:
        parts.append(f"obj {_number(event.objective)}")
    if event.dual_bound is not None:
        parts.append(f"bound {_number(event.dual_bound)}")
    detail = event.detail.removeprefix(f"level {event.level}: ")  # said already
    parts.append(detail or ("new incumbent" if event.phase == INCUMBENT else event.phase))
    return "  ".join(parts)


def summary_line(layout: Layout) -> str:
    r = layout.report
    soft = (f"  soft violations {len(r.violations)} ({r.total_shortfall:.2f} m short)"
            if r.violations else "")
    floors = f" on {len(layout.floors)} floors" if layout.floors is not None else ""
    return (f"{len(layout.all_rooms)} rooms{floors}  coverage {r.coverage:.1%}  "
            f"levels {r.levels}  termination {r.termination.value}  "
            f"valid {'yes' if r.valid else 'no'}{soft}  solve time {r.solve_time:.2f} s")


def invalid_layout_warning(layout: Layout) -> str:
    failed = [c for c in layout.report.constraints if not c.satisfied]
    lines = [f"{PROG}: warning: the layout fails {len(failed)} check(s):"]
    for c in failed:
        rooms = ", ".join(c.rooms)
        lines.append(f"  {c.kind}{' ' + rooms if rooms else ''}"
                     f"{' on floor ' + c.floor if c.floor else ''}"
                     f"{': ' + c.detail if c.detail else ''}")
    return "\n".join(lines)


def soft_violations_note(layout: Layout) -> str:
    """The soft constraints a valid layout breaks (issue 8), each with its shortfall."""
    r = layout.report
    lines = [f"{PROG}: {len(r.violations)} soft constraint(s) not met, "
             f"{r.total_shortfall:.2f} m short in all:"]
    for c in r.violations:
        lines.append(f"  {c.kind} {', '.join(c.rooms)}: {c.shortfall:.2f} m short"
                     f"{' (' + c.detail + ')' if c.detail else ''}")
    return "\n".join(lines)


def no_layout_message(layout: Layout) -> str:
    r = layout.report
    why = r.infeasibility
    lines = [f"{PROG}: no layout ({r.termination.value}): "
             f"{why.reason if why else 'no reason given'}"]
    if why is not None:
        if why.conflict is not None:
            lines.append(f"  {why.conflict.explanation}")
            lines += _section("constraints in conflict", [
                f"{c.path}: {c.constraint}" for c in why.conflict.constraints])
        lines += _section("findings", why.findings)
        lines += _section("relaxations tried", why.relaxations_tried)
        lines += _section("constraint families", why.active_families)
    return "\n".join(lines)


def _section(title: str, items: Sequence[str]) -> list[str]:
    return [f"  {title}:", *(f"    - {item}" for item in items)] if items else []


def _number(value: float) -> str:
    if not math.isfinite(value) or abs(value) >= SCIP_INFINITY:
        return "-inf" if value < 0 else "inf"
    if abs(value) >= 1e6:
        return f"{value:.3g}"
    return f"{round(value, 2) + 0.0:.2f}"  # + 0.0: no "-0.00"
