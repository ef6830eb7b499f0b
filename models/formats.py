"""What a layout can be written as: the one list of its output formats, each with its
media type, its file extensions and whether it is text or bytes. The service's
``GET /v1/layouts/{id}/result?format=``, ``floorplan solve --format`` and ``floorplan
submit --format`` offer these.

Standard library only: the `floorplan` command reads it while it builds its options,
before anything heavy may load (see `models`).

>>> [f.name for f in FORMATS]
['json', 'svg', 'dxf', 'geojson', 'ifc']
>>> format_of("plan.SVG"), format_of("/dev/null"), format_of("-")
('svg', 'json', 'json')
>>> MEDIA_TYPES["geojson"]
'application/geo+json'
>>> in_words()[:60]
'the layout JSON, an SVG plan, a DXF drawing in metres, GeoJS'
>>> in_words()[60:]
'ON (local metres, or WGS84 with an origin), or an IFC4 building model'
"""

from __future__ import annotations

import math
import os
import stat
import sys
from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import Literal, get_args

#: The name of an output format (what ``format=`` and ``--format`` take).
FormatName = Literal["json", "svg", "dxf", "geojson", "ifc"]
#: The formats rendered from a layout, as opposed to the layout JSON itself.
RenderedFormatName = Literal["svg", "dxf", "geojson", "ifc"]


@dataclass(frozen=True)
class OutputFormat:
    """One format a layout can be written in."""

    name: FormatName
    media_type: str
    extensions: tuple[str, ...]
    """File name extensions, without the dot, lower case; the first is the one to give."""
    binary: bool
    """True when the file is bytes to be written as they are, False when it is UTF-8 text."""
    description: str
    """What the file holds, for help texts."""
    inline: bool = False
    """True when a browser should show it rather than download it (a plan)."""

    @property
    def extension(self) -> str:
        """The extension a file of this format gets (``svg``)."""
        return self.extensions[0]


#: Every output format, the layout JSON first (the default).
FORMATS: tuple[OutputFormat, ...] = (
    OutputFormat("json", "application/json", ("json",), binary=False,
                 description="the layout JSON"),
    OutputFormat("svg", "image/svg+xml", ("svg",), binary=False,
                 description="an SVG plan", inline=True),
    OutputFormat("dxf", "image/vnd.dxf", ("dxf",), binary=False,
                 description="a DXF drawing in metres"),
    OutputFormat("geojson", "application/geo+json", ("geojson",), binary=False,
                 description="GeoJSON (local metres, or WGS84 with an origin)"),
    # IFC's STEP physical file (ISO 10303-21): ASCII text. IANA registers no type for
    # it; application/x-step is what BIM servers and buildingSMART's tools send.
    OutputFormat("ifc", "application/x-step", ("ifc",), binary=False,
                 description="an IFC4 building model"),
)
#: How high each storey of the IFC model is unless asked otherwise, metres, and the
#: heights it may be: the lowest above the doors (2.1 m), the highest a tall hall's.
DEFAULT_STOREY_HEIGHT = 3.0
MIN_STOREY_HEIGHT = 2.4
MAX_STOREY_HEIGHT = 20.0
#: The layers of the DXF drawing: the AIA / US National CAD Standard names (``A-WALL``,
#: ``A-AREA``, ...), or the older layer per room type (``ROOM_BEDROOM``).
DxfLayers = Literal["ncs", "room-type"]
DXF_LAYERS: tuple[DxfLayers, ...] = get_args(DxfLayers)


@dataclass(frozen=True)
class ExportOptions:
    """How a rendered format is drawn, where the format leaves a choice."""

    storey_height: float = DEFAULT_STOREY_HEIGHT
    """IFC: metres from one storey's floor to the next; walls and spaces are as high."""
    dxf_layers: DxfLayers = "ncs"
    """DXF: the layer names (see `DxfLayers`)."""
    origin: tuple[float, float] | None = None
    """GeoJSON: where the plan's origin lies on the map, (latitude, longitude) in WGS84
    degrees, its +y due north; None keeps the plan's local metres."""

    def __post_init__(self) -> None:
        if not MIN_STOREY_HEIGHT <= self.storey_height <= MAX_STOREY_HEIGHT:
            raise ValueError(f"storey_height must be {MIN_STOREY_HEIGHT} to "
                             f"{MAX_STOREY_HEIGHT} m, not {self.storey_height}")
        if self.dxf_layers not in DXF_LAYERS:
            raise ValueError(f"dxf_layers must be one of {DXF_LAYERS}, not {self.dxf_layers!r}")
        if self.origin is not None:
            lat, lon = self.origin
            if not (-85.0 <= lat <= 85.0 and -180.0 <= lon <= 180.0):
                raise ValueError(f"origin must be a latitude of -85 to 85 and a longitude "
                                 f"of -180 to 180 degrees, not {lat:g},{lon:g}")


#: The formats by name.
BY_NAME: dict[str, OutputFormat] = {f.name: f for f in FORMATS}
#: The names of the formats, in order (for ``choices=``).
FORMAT_NAMES: tuple[FormatName, ...] = tuple(f.name for f in FORMATS)
#: The names of the formats rendered from a layout (all but ``json``).
RENDERED_FORMAT_NAMES: tuple[RenderedFormatName, ...] = tuple(
    name for name in FORMAT_NAMES if name != "json")
#: Format name -> media type.
MEDIA_TYPES: dict[str, str] = {f.name: f.media_type for f in FORMATS}
#: The format a layout is in unless asked otherwise.
DEFAULT_FORMAT: FormatName = "json"

# The type checkers' names and the registry must agree.
assert get_args(FormatName) == FORMAT_NAMES, "FormatName and FORMATS disagree"
assert get_args(RenderedFormatName) == RENDERED_FORMAT_NAMES, "RenderedFormatName disagrees"


def storey_height_of(text: str) -> float:
    """A storey height written out (a command-line option), checked; ValueError says
    what is wrong with it.

    >>> storey_height_of("3.2")
    3.2
    >>> storey_height_of("1")
    Traceback (most recent call last):
    ...
    ValueError: storey_height must be 2.4 to 20.0 m, not 1.0
    """
    try:
        height = float(text)
    except ValueError:
        raise ValueError(f"not a number of metres: {text!r}") from None
    return ExportOptions(storey_height=height).storey_height


def origin_of(text: str) -> tuple[float, float]:
    """An origin written ``LAT,LON`` (decimal degrees, WGS84), checked; ValueError says
    what is wrong with it.

    >>> origin_of("52.5163, 13.3777")
    (52.5163, 13.3777)
    >>> origin_of("91,0")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: origin must be a latitude of -85 to 85 and a longitude of -180 to 180 ...
    """
    parts = text.split(",")
    try:
        lat, lon = (float(part) for part in parts)
    except ValueError:
        raise ValueError(f"origin must be LAT,LON in decimal degrees, not {text!r}") from None
    if not all(math.isfinite(v) for v in (lat, lon)):
        raise ValueError(f"origin must be LAT,LON in decimal degrees, not {text!r}")
    return ExportOptions(origin=(lat, lon)).origin or (lat, lon)


def storey_height_arg(text: str) -> float:
    """``--storey-height``'s metres for argparse (``type=``): `storey_height_of`, its
    ValueError as argparse's own error, which names the option."""
    import argparse

    try:
        return storey_height_of(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def origin_arg(text: str) -> tuple[float, float]:
    """``--origin``'s LAT,LON for argparse (``type=``), as `storey_height_arg`."""
    import argparse

    try:
        return origin_of(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


class UnknownFormat(ValueError):
    """A file name whose extension names none of the formats."""


def format_of(filename: str, default: FormatName = DEFAULT_FORMAT) -> FormatName:
    """The format a file name asks for by its extension (any case): `default` for a name
    without one (``-``, ``/dev/null``); `UnknownFormat` for an extension no format has,
    rather than a file whose name says one thing and whose content another.

    >>> try:
    ...     format_of("plan.pdf")
    ... except UnknownFormat as err:
    ...     print(err)
    plan.pdf: no format has the extension .pdf (json, svg, dxf, geojson, ifc); give --format
    """
    suffix = PurePath(filename).suffix.lower().lstrip(".")
    if not suffix or filename == STDIO:
        return default
    for fmt in FORMATS:
        if suffix in fmt.extensions:
            return fmt.name
    raise UnknownFormat(f"{filename}: no format has the extension .{suffix} "
                        f"({', '.join(FORMAT_NAMES)}); give --format")


def in_words() -> str:
    """The formats for a help text: ``the layout JSON, an SVG plan, ..., or GeoJSON ...``."""
    words = [f.description for f in FORMATS]
    return ", ".join(words[:-1]) + ", or " + words[-1]


#: The file name that means standard input or output on the command line.
STDIO = "-"


def why_unwritable(target: str) -> str | None:
    """Why `write_file` could not write `target` (a file, not a folder of files), as the
    message of a refusal before any work is done; None when it can. A device or FIFO
    is written in place, so it is its own permission that counts; a file is written
    beside its name and renamed, so it is its folder's."""
    if target == STDIO:
        return None
    path = Path(os.path.realpath(target))
    if path.is_dir():
        return f"{target}: is a directory"
    if path.exists() and not path.is_file():
        return None if os.access(path, os.W_OK) else f"{target}: not writable"
    if not path.parent.is_dir():
        return f"{target}: directory {path.parent} does not exist"
    if not os.access(path.parent, os.W_OK):
        return f"{target}: directory {path.parent} is not writable"
    return None


def write_text_file(target: str, text: str) -> None:
    """`write_file` of UTF-8 text."""
    if target == STDIO:
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    write_file(target, text.encode("utf-8"))


def write_file(target: str, data: bytes) -> None:
    """Write `data` to `target`, as `floorplan solve` and `floorplan submit` both do,
    never clobbering what the name stands for: `STDIO` is standard output; a symbolic
    link is followed (the link stays, its target is written); a regular file, or a new
    one, is written beside its final name and renamed over it, so that a reader never
    sees half a file (the file's permissions kept); anything else (a device such as
    /dev/null, a FIFO, a socket) is opened and written in place, as a shell's ``>``
    would."""
    if target == STDIO:
        sys.stdout.flush()
        sys.stdout.buffer.write(data)
        sys.stdout.buffer.flush()
        return
    path = Path(os.path.realpath(target))
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        mode = None
    if mode is not None and not stat.S_ISREG(mode):
        with open(path, "wb") as stream:
            stream.write(data)
        return
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_bytes(data)
        if mode is not None:
            os.chmod(tmp, stat.S_IMODE(mode))
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
