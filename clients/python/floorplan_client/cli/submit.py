"""``floorplan submit``: its arguments (`add_submit`), and the command (`cmd_submit`):
the problem sent, the job followed until it ends, its layout written."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from floorplan_client.cli.batch import submit_batch
from floorplan_client.cli.display import (
    Say,
    make_display,
    no_layout_message,
    submit_failed,
    summary_line,
)
from floorplan_client.cli.exits import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_INVALID,
    EXIT_NO_LAYOUT,
    EXIT_OK,
    PROG,
    UsageError,
)
from floorplan_client.cli.files import (
    STDIO,
    check_writable,
    load_problem,
    output_format,
    write_outputs,
)
from floorplan_client.models.formats import (
    DEFAULT_STOREY_HEIGHT,
    DXF_LAYERS,
    FORMAT_NAMES,
    in_words,
    origin_arg,
    storey_height_arg,
)

if TYPE_CHECKING:
    from floorplan_client import Job

#: What -o can hold: the layout JSON, or the service's SVG, DXF or GeoJSON rendering.
FORMATS = FORMAT_NAMES
#: Seconds to wait for a job to end once Ctrl-C has canceled it.
CANCEL_WAIT = 30.0


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
    p.add_argument("--svg", metavar="PLAN.svg", help="also write the plan as SVG here")
    p.add_argument("--time-limit", type=float, metavar="S",
                   help="seconds for the solve (overrides options.time_limit)")
    p.add_argument("--seed", type=int, metavar="K", help="random seed (overrides options.seed)")
    p.add_argument("--count", type=int, metavar="N",
                   help="a batch: N layouts of the problem, seeds --seed (default "
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
        return submit_batch(args)
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
        check_writable(target)
    args.format = output_format(args.output, args.format)

    say = Say(sys.stderr, quiet=args.quiet)
    api_key = NOT_GIVEN if args.api_key is None else args.api_key
    with Client(args.server, api_key=api_key) as fp:
        try:
            job = fp.submit(problem)
        except FloorplanError as err:
            return submit_failed(args.problem, err)
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


def _follow(job: Job, args: argparse.Namespace, say: Say) -> int:
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
        if report is not None and not write_outputs(job, report, args, svg=False):
            return EXIT_FAILURE
        print(no_layout_message(err), file=sys.stderr)
        return EXIT_NO_LAYOUT
    if not write_outputs(job, layout, args, svg=True):
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
