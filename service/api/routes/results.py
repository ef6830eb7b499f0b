"""A layout job's result (/v1/layouts/{id}/result): the layout JSON, and one operation
per rendered format (/result/svg, /result/dxf, /result/geojson, /result/ifc), each
answering in one media type so that a client generated from the OpenAPI document
knows what it gets. ``/result?format=`` still answers in any format (the web page and
older clients use it); the schema documents it as JSON only."""

from __future__ import annotations

from functools import partial
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request, Response

from floorplan.models import Layout
from floorplan.models import Problem as LayoutProblem
from floorplan.models.formats import (
    BY_NAME,
    DEFAULT_FORMAT,
    DEFAULT_STOREY_HEIGHT,
    MAX_STOREY_HEIGHT,
    MEDIA_TYPES,
    MIN_STOREY_HEIGHT,
    DxfLayers,
    ExportOptions,
    FormatName,
    origin_of,
)
from floorplan.models.jobs import FieldError
from floorplan.models.options import MAX_VARIANTS
from floorplan.service.api.body import run_off_loop
from floorplan.service.api.deps import JobDep, LimitsDep, store_dep
from floorplan.service.api.errors import ApiError
from floorplan.service.records import Job
from floorplan.solver.export import render

router = APIRouter(prefix="/v1/layouts", tags=["results"])

StoreyHeight = Annotated[float, Query(
    ge=MIN_STOREY_HEIGHT, le=MAX_STOREY_HEIGHT,
    description="metres from one storey's floor to the next (the IFC storeys, the DXF "
    "storeys' elevations)")]
Layers = Annotated[DxfLayers, Query(
    description="'ncs', the AIA / US National CAD Standard layers (A-WALL, A-AREA, ...), "
    "or 'room-type', the older layer per room type")]
Variant = Annotated[int | None, Query(
    ge=0, lt=MAX_VARIANTS, description="with options.variants: the design variant to give, "
    "0 the best (the layout itself), in the order of `variants`; a 404 when the job found "
    "fewer")]
Origin = Annotated[str | None, Query(
    max_length=100, examples=["52.5163,13.3777"],
    description="'LAT,LON' in decimal degrees (WGS84): the GeoJSON in longitude and "
    "latitude, the plan's origin there and its +y due north; without it, local metres")]

_NO_RESULT = {"description": "unknown job, no layout yet, or no such variant"}
_LOST = {"description": "the export process was lost (it is replaced): try again"}


def _media(fmt: FormatName, schema: dict[str, Any], description: str) -> dict[int | str, Any]:
    return {200: {"description": description,
                  "content": {MEDIA_TYPES[fmt]: {"schema": schema}}},
            404: _NO_RESULT, 503: _LOST}


_BINARY = {"type": "string", "format": "binary"}


@router.get("/{job_id}/result", response_model=Layout, operation_id="getLayoutResult",
            responses={404: _NO_RESULT, 503: _LOST})
async def get_layout_result(
    job: JobDep, request: Request, limits: LimitsDep, variant: Variant = None,
    # The older spelling of the per-format operations, kept for the clients that use it.
    format: Annotated[FormatName, Query(include_in_schema=False)] = DEFAULT_FORMAT,
    storey_height: Annotated[float, Query(
        ge=MIN_STOREY_HEIGHT, le=MAX_STOREY_HEIGHT,
        include_in_schema=False)] = DEFAULT_STOREY_HEIGHT,
    dxf_layers: Annotated[DxfLayers, Query(include_in_schema=False)] = "ncs",
    origin: Annotated[str | None, Query(max_length=100, include_in_schema=False)] = None,
) -> Response:
    """The layout as JSON: the final one, or the best so far while the job runs. With
    `variant`, that design variant of the final layout. The other formats are the
    /result/svg, /result/dxf, /result/geojson and /result/ifc operations."""
    return await _answer(request, limits, job, format, variant, ExportOptions(
        storey_height=storey_height, dxf_layers=dxf_layers, origin=_origin(origin)))


@router.get("/{job_id}/result/svg", operation_id="getLayoutSvg", response_class=Response,
            responses=_media("svg", {"type": "string"}, "the plan, an SVG document"))
async def get_layout_svg(job: JobDep, request: Request, limits: LimitsDep,
                         variant: Variant = None) -> Response:
    """The layout drawn as an SVG plan (metres, north up)."""
    return await _answer(request, limits, job, "svg", variant, ExportOptions())


@router.get("/{job_id}/result/dxf", operation_id="getLayoutDxf", response_class=Response,
            responses=_media("dxf", _BINARY, "a DXF drawing in metres"))
async def get_layout_dxf(job: JobDep, request: Request, limits: LimitsDep,
                         variant: Variant = None, dxf_layers: Layers = "ncs",
                         storey_height: StoreyHeight = DEFAULT_STOREY_HEIGHT) -> Response:
    """The layout as a DXF drawing (metres), one block of rooms and walls per storey."""
    return await _answer(request, limits, job, "dxf", variant,
                         ExportOptions(storey_height=storey_height, dxf_layers=dxf_layers))


@router.get("/{job_id}/result/geojson", operation_id="getLayoutGeojson",
            response_class=Response,
            responses=_media("geojson", {"type": "object", "additionalProperties": True},
                             "a GeoJSON FeatureCollection (RFC 7946)"))
async def get_layout_geojson(job: JobDep, request: Request, limits: LimitsDep,
                             variant: Variant = None, origin: Origin = None) -> Response:
    """The layout as a GeoJSON FeatureCollection: with `origin`, in WGS84 longitude and
    latitude; without it, in the plan's local metres (docs/exports.md)."""
    return await _answer(request, limits, job, "geojson", variant,
                         ExportOptions(origin=_origin(origin)))


@router.get("/{job_id}/result/ifc", operation_id="getLayoutIfc", response_class=Response,
            responses=_media("ifc", _BINARY, "an IFC4 building model (STEP, metres)"))
async def get_layout_ifc(job: JobDep, request: Request, limits: LimitsDep,
                         variant: Variant = None,
                         storey_height: StoreyHeight = DEFAULT_STOREY_HEIGHT) -> Response:
    """The layout as an IFC4 building model: site, building, a storey per floor,
    spaces, walls, doors."""
    return await _answer(request, limits, job, "ifc", variant,
                         ExportOptions(storey_height=storey_height))


def _origin(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        return origin_of(text)
    except ValueError as err:
        raise ApiError(422, str(err), kind="invalid-request", errors=[FieldError(
            field="origin", loc=["query", "origin"], message=str(err), type="value_error",
        )]) from None


async def _answer(request: Request, limits: LimitsDep, job: Job, fmt: FormatName,
                  variant: int | None, options: ExportOptions) -> Response:
    """`job`'s layout (or its design variant `variant`) in `fmt`; a 404 when it has none.
    Exports are made in the API's export processes (FLOORPLAN_EXPORT_PROCESSES at once):
    an IFC of a large layout takes seconds that would otherwise hold up every other
    request."""
    text = job.result or job.incumbent
    if text is None:
        raise ApiError(404, f"job {job.id} has no layout yet (status {job.status})",
                       kind="no-result-yet", title="No layout yet")
    if variant is not None:
        text = await run_off_loop(request, partial(_variant_text, job, variant))
    if fmt == "json":
        return Response(text, media_type=MEDIA_TYPES["json"])
    # A batch's layout: its problem derived from the brief (off the event loop).
    job = await run_off_loop(request, partial(store_dep(request).with_problem, job))
    body = await limits.run_export(partial(export, job.problem, text, fmt, options))
    # A plan shows in the browser; drawings and data download as files.
    disposition = "inline" if BY_NAME[fmt].inline else "attachment"
    headers = {"Content-Disposition":
               f'{disposition}; filename="{job.id}.{BY_NAME[fmt].extension}"'}
    return Response(body, media_type=MEDIA_TYPES[fmt], headers=headers)


def export(problem: str, layout: str, fmt: FormatName, options: ExportOptions) -> bytes:
    """A stored job's layout (JSON) in `fmt`: in an export process."""
    return render(LayoutProblem.model_validate_json(problem), Layout.model_validate_json(layout),
                  fmt, options)


def _variant_text(job: Job, index: int) -> str:
    """Design variant `index` of `job`'s final layout, as JSON; a 404 when the job has
    not ended yet or found fewer variants."""
    if job.result is None:
        raise ApiError(404, f"job {job.id} has no final layout yet (status {job.status}): "
                       "variants come with it", kind="no-result-yet", title="No layout yet")
    layout = Layout.model_validate_json(job.result)
    variants = layout.variants if layout.variants is not None else (
        [layout] if layout.all_rooms else [])
    if index >= len(variants):
        raise ApiError(404, f"job {job.id} has {len(variants)} variant(s); there is no "
                       f"variant {index}", kind="no-such-variant", title="No such variant")
    return variants[index].model_dump_json()
