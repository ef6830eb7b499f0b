"""The `floorplan` command line: solve a problem file from the shell.

    floorplan solve PROBLEM.json -o LAYOUT.json [--svg PLAN.svg] [--time-limit S]
                    [--seed K] [--max-levels N] [--variants N] [--processes N] [--quiet]
                    [--expand]

With ``-o DIR/`` (a name ending in '/', or an existing directory) every design variant
(options.variants) is written to DIR as ``variant-1.json``, ``variant-2.json``, ...
(best first, in --format); ``--svg DIR/`` likewise draws each as ``variant-<i>.svg``.

Progress goes to stderr (one line per solver event, new incumbents at most a few
times a second), then a one-line summary; the layout JSON goes to ``-o`` (stdout when
``-o`` is ``-`` or omitted); progress.py writes those lines. Exit codes are the
constants ``EXIT_*`` of exits.py.

Ctrl-C stops the solve gracefully: the best layout found so far is written (exit 0,
``report.termination`` "interrupted"; 130 when there was none yet). A second Ctrl-C
aborts at once with 130 (see `sigint_flag` in interrupt.py for how the signal is kept
from SCIP). For that, this module imports the solver (and with it numpy, which starts
native threads) only once SIGINT is blocked: keep its top-level imports, and those of
the modules it imports (exits.py, interrupt.py, progress.py), to the standard library.

The parser is built from subcommands so that ``serve`` and ``submit`` can join ``solve``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from floorplan.models.formats import (
    DEFAULT_STOREY_HEIGHT,
    DXF_LAYERS,
    FORMAT_NAMES,
    STDIO,
    FormatName,
    UnknownFormat,
    format_of,
    in_words,
    origin_arg,
    storey_height_arg,
    why_unwritable,
    write_file,
    write_text_file,
)
from floorplan.service.cli.exits import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_INVALID,
    EXIT_NO_LAYOUT,
    EXIT_OK,
    PROG,
)
from floorplan.service.cli.interrupt import keep_sigint_blocked, sigint_flag
from floorplan.service.cli.progress import (
    ProgressPrinter,
    invalid_layout_warning,
    no_layout_message,
    soft_violations_note,
    summary_line,
)

if TYPE_CHECKING:
    from pydantic import ValidationError

    from floorplan.models import Layout, Problem

#: Objects up to this many characters (with their indent) stay on one line in --expand.
READABLE_WIDTH = 88

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
        epilog=f"'{PROG} COMMAND --help' tells more of each.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
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
    p.add_argument("--format", choices=FORMAT_NAMES,
                   help=f"what -o holds (default: from its extension, else json): {in_words()}")
    p.add_argument("--storey-height", type=storey_height_arg, metavar="M",
                   default=DEFAULT_STOREY_HEIGHT,
                   help="ifc: metres from one storey's floor to the next (default "
                   f"{DEFAULT_STOREY_HEIGHT:g}; also the DXF storeys' elevations)")
    p.add_argument("--dxf-layers", choices=DXF_LAYERS, default="ncs",
                   help="dxf: 'ncs' the AIA / US National CAD Standard layers (A-WALL, "
                   "A-AREA, ...; default), 'room-type' the older layer per room type")
    p.add_argument("--origin", type=origin_arg, metavar="LAT,LON",
                   help="geojson: put the plan's origin at this latitude and longitude "
                   "(WGS84 degrees), +y due north, and write longitude and latitude "
                   "(default: the plan's local metres)")
    p.add_argument("--time-limit", type=float, metavar="S",
                   help="seconds for the whole solve (overrides options.time_limit)")
    p.add_argument("--seed", type=int, metavar="K", help="random seed (overrides options.seed)")
    p.add_argument("--variants", type=int, metavar="N",
                   help="design variants to look for, 1-12 (overrides options.variants): "
                   "distinct valid layouts ranked best first; with -o DIR/ each is written "
                   "to its own file there")
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


def _version() -> str:
    """The installed distribution's version (standard library only: see the module)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("floorplan-miqp")
    except PackageNotFoundError:  # run from a checkout that is not installed
        return "unknown"


def output_format(target: str | None, given: FormatName | None) -> FormatName:
    """What `target` is to hold: `given` (--format), else by its extension; an extension
    no format has is refused (`UsageError`) rather than written as JSON."""
    if given is not None:
        return given
    if target is None or is_directory_target(target):
        return "json"
    try:
        return format_of(target)
    except UnknownFormat as err:
        raise UsageError(str(err)) from None


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
    if args.command is None:  # a bare `floorplan`: what it can do, and a usage error
        parser.print_help(sys.stderr)
        return EXIT_INVALID
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
                             max_levels=args.max_levels, variants=args.variants)
    if args.expand:
        return write_expanded(args, problem)

    from floorplan.models import Termination
    from floorplan.solver import solve
    from floorplan.solver.pipeline.pool import end_pool, subdomain_pool
    from floorplan.solver.pipeline.subdomains import SubdomainExecutor

    for target in (args.output, args.svg):
        _check_writable(target)
    args.format = output_format(args.output, args.format)
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
    if args.svg or output_format(args.output, args.format) != "json":
        raise UsageError("--expand writes the problem as JSON: drop --svg and --format, "
                         "and give -o a .json name")
    _check_writable(args.output)
    try:
        write_text_file(args.output,
                        readable_json(problem.model_dump(mode="json", exclude_unset=True))
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

    from floorplan.models import Problem

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

    from floorplan.models import Options

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


def is_directory_target(target: str | None) -> bool:
    """Whether `target` names a directory to write one file per variant into: it ends
    with a path separator or is an existing directory."""
    return target is not None and target != STDIO and (
        target.endswith(("/", os.sep)) or Path(target).is_dir())


def _check_writable(target: str | None) -> None:
    """Refuse before solving rather than lose the result afterwards."""
    if target is None or target == STDIO:
        return
    if is_directory_target(target):
        path = Path(target).resolve()
        if not path.is_dir() and not path.parent.is_dir():
            raise UsageError(f"{target}: directory {path.parent} does not exist")
        if path.is_dir() and not os.access(path, os.W_OK):
            raise UsageError(f"{target}: directory is not writable")
        return
    reason = why_unwritable(target)
    if reason is not None:
        raise UsageError(reason)


def _write_outputs(args: argparse.Namespace, problem: Problem, layout: Layout) -> bool:
    """Write the layout (in --format, settled before the solve) and the SVG; False
    (with a message) when one failed."""
    from floorplan.models.formats import BY_NAME, ExportOptions
    from floorplan.solver.export import render
    from floorplan.solver.export.svg import render_svg

    ok = True
    fmt = args.format
    options = ExportOptions(storey_height=args.storey_height, dxf_layers=args.dxf_layers,
                            origin=args.origin)

    def encoded(one: Layout) -> bytes:
        if fmt == "json":
            return (one.model_dump_json(indent=2) + "\n").encode()
        return render(problem, one, fmt, options)

    variants = layout.variants or [layout]
    try:
        if is_directory_target(args.output):
            Path(args.output).mkdir(exist_ok=True)
            for i, variant in enumerate(variants, start=1):
                target = str(Path(args.output) / f"variant-{i}.{BY_NAME[fmt].extension}")
                write_file(target, encoded(variant))
        elif args.output == STDIO and fmt == "json":
            write_text_file(STDIO, encoded(layout).decode())
        else:
            write_file(args.output, encoded(layout))
    except OSError as err:
        print(f"{PROG}: error: cannot write {args.output}: {err}", file=sys.stderr)
        ok = False
    if args.svg and is_directory_target(args.svg):
        try:
            Path(args.svg).mkdir(exist_ok=True)
            for i, variant in enumerate(variants, start=1):
                write_text_file(str(Path(args.svg) / f"variant-{i}.svg"),
                            render_svg(problem, variant))
        except OSError as err:
            print(f"{PROG}: error: cannot write {args.svg}: {err}", file=sys.stderr)
            ok = False
    elif args.svg:
        try:
            write_text_file(args.svg, render_svg(problem, layout))
        except OSError as err:
            print(f"{PROG}: error: cannot write {args.svg}: {err}", file=sys.stderr)
            ok = False
    return ok
