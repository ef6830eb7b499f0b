"""Layouts as files: one writer per output format, and `render` choosing among them.

The formats are JSON (the layout itself), SVG plans (`svg.py`), DXF drawings (`dxf.py`),
GeoJSON (`geojson.py`) and IFC4 building models (`ifc.py`), all in the problem's own
metric frame. Adding a format is a writer here plus its entry in `models.formats`
(docs/architecture.md). The choices a format leaves (a storey's height, the DXF's
layer names) are `models.formats.ExportOptions`."""

from __future__ import annotations

import json
from collections.abc import Callable

from floorplan.models import Layout, Problem
from floorplan.models.formats import ExportOptions, FormatName

Writer = Callable[[Problem, Layout, ExportOptions], bytes]


# Each writer imports its module when first used: ezdxf and ifcopenshell take about a
# second to import, which `floorplan solve` writing JSON and SVG need not wait for.
def _svg(problem: Problem, layout: Layout, options: ExportOptions) -> bytes:
    from floorplan.solver.export.svg import render_svg

    return render_svg(problem, layout).encode()


def _dxf(problem: Problem, layout: Layout, options: ExportOptions) -> bytes:
    from floorplan.solver.export.dxf import to_dxf

    return to_dxf(problem, layout, layers=options.dxf_layers,
                  storey_height=options.storey_height)


def _geojson(problem: Problem, layout: Layout, options: ExportOptions) -> bytes:
    from floorplan.solver.export.geojson import to_geojson

    return json.dumps(to_geojson(problem, layout, options.origin), indent=1).encode()


def _ifc(problem: Problem, layout: Layout, options: ExportOptions) -> bytes:
    from floorplan.solver.export.ifc import to_ifc

    return to_ifc(problem, layout, storey_height=options.storey_height)


#: The writer of each format of `models.formats`: the bytes of the file.
WRITERS: dict[str, Writer] = {
    "json": lambda problem, layout, _: layout.model_dump_json(indent=2).encode(),
    "svg": _svg,
    "dxf": _dxf,
    "geojson": _geojson,
    "ifc": _ifc,
}


def render(problem: Problem, layout: Layout, fmt: FormatName,
           options: ExportOptions | None = None) -> bytes:
    """`layout` in `fmt`, as the bytes of a file, drawn as `options` say (else the
    defaults)."""
    return WRITERS[fmt](problem, layout, options or ExportOptions())
