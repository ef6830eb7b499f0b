"""``floorplan submit``'s input and output: the problem file (or stdin), the layout
and plan written whole (write, then rename), targets refused before a job is sent."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from floorplan_client.cli.exits import PROG, UsageError
from floorplan_client.models.formats import (
    STDIO,
    FormatName,
    UnknownFormat,
    format_of,
    why_unwritable,
    write_file,
    write_text_file,
)

if TYPE_CHECKING:
    from floorplan_client import Job
    from floorplan_client.models import Layout


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


def check_writable(target: str | None) -> None:
    """Refuse before submitting rather than lose the layout afterwards."""
    if target is None:
        return
    reason = why_unwritable(target)
    if reason is not None:
        raise UsageError(reason)


def output_format(target: str | None, given: FormatName | None) -> FormatName:
    """What -o is to hold: --format, else by its extension; an extension no format has
    is refused (`UsageError`) rather than written as JSON."""
    if given is not None:
        return given
    try:
        return format_of(target or STDIO)
    except UnknownFormat as err:
        raise UsageError(str(err)) from None


def write_outputs(job: Job, layout: Layout, args: argparse.Namespace, *, svg: bool) -> bool:
    """Write the layout (in -o's format) and, when asked and `svg`, the plan; False
    after a failure."""
    ok = True
    target = args.output or STDIO
    fmt = output_format(target, args.format)
    try:
        if fmt == "json":
            write_text_file(target, layout.model_dump_json(indent=2) + "\n")
        else:
            text = job.result(format=fmt, storey_height=args.storey_height,
                              dxf_layers=args.dxf_layers, origin=args.origin)
            write_file(target, text.encode())
    except OSError as err:
        print(f"{PROG}: error: cannot write {target}: {err}", file=sys.stderr)
        ok = False
    if svg and args.svg:
        try:
            write_text_file(args.svg, job.result(format="svg"))
        except OSError as err:
            print(f"{PROG}: error: cannot write {args.svg}: {err}", file=sys.stderr)
            ok = False
    return ok
