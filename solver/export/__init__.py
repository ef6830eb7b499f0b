"""Layouts as files: one writer per output format, and `render` choosing among them.

The formats are JSON (the layout itself), SVG plans (`svg.py`), DXF drawings (`dxf.py`)
and GeoJSON (`geojson.py`), all in the problem's own metric frame. Adding a format is a
writer here plus its entry in `models.formats` (docs/architecture.md)."""

from __future__ import annotations

import json
from collections.abc import Callable

from models import Layout, Problem
from models.formats import FormatName
from solver.export.dxf import to_dxf
from solver.export.geojson import to_geojson
from solver.export.svg import render_svg

Writer = Callable[[Problem, Layout], bytes]
#: The writer of each format of `models.formats`: the bytes of the file.
WRITERS: dict[str, Writer] = {
    "json": lambda problem, layout: layout.model_dump_json(indent=2).encode(),
    "svg": lambda problem, layout: render_svg(problem, layout).encode(),
    "dxf": to_dxf,
    "geojson": lambda problem, layout: json.dumps(to_geojson(problem, layout),
                                                  indent=1).encode(),
}


def render(problem: Problem, layout: Layout, fmt: FormatName) -> bytes:
    """`layout` in `fmt`, as the bytes of a file."""
    return WRITERS[fmt](problem, layout)
