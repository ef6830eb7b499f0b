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
at once. Exit codes are `EXIT_*` (`cli.exits`), the same as ``floorplan solve``'s.

The `floorplan` command (``service/cli/``) adds this subcommand with `add_submit`
when this package is installed. That command also runs ``floorplan solve``, which must
not load numpy before it has set up its Ctrl-C handling: keep this package's top-level
imports to the standard library and `models.formats` (the formats -o can hold, itself
standard library only; the `models` package loads its other modules on first use).

The modules: `submit` (the arguments and the command), `batch` (``--count``), `files`
(the problem read, the layout written), `display` (messages and the progress display),
`exits` (the exit codes).
"""

from __future__ import annotations

from floorplan_client.cli.exits import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_INVALID,
    EXIT_NO_LAYOUT,
    EXIT_OK,
)
from floorplan_client.cli.submit import add_submit, cmd_submit

__all__ = [
    "EXIT_FAILURE",
    "EXIT_INTERRUPTED",
    "EXIT_INVALID",
    "EXIT_NO_LAYOUT",
    "EXIT_OK",
    "add_submit",
    "cmd_submit",
]
