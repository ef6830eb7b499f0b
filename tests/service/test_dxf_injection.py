"""User strings cannot write DXF structure: a floor name or a room id holding newlines
and group codes, solved by a real server process on loopback and fetched as DXF (both
layer schemes), is read back with ezdxf and line by line: every value stays one value,
and no layer or entity of the attacker's appears."""

from __future__ import annotations

import io
from collections.abc import Iterator
from typing import Any

import ezdxf
import httpx2 as httpx
import pytest

from tests.servers import Server
from tests.service.test_service import wait

QUIET = {"WORKERS": "1", "FLOORPLAN_SUBDOMAIN_PROCESSES": "1"}
#: Group codes that, were the name written raw, would end the value, put the rest on
#: a layer PWNEDFLOOR and start a LINE on layer PWNED (the review's file).
PAYLOAD = "\n  8\nPWNEDFLOOR\n  0\nLINE\n  8\nPWNED\n 10\n0\n 20\n0\n 11\n100\n 21\n100\n"


def hostile_building() -> dict[str, Any]:
    """Two storeys of four 2 x 2 m rooms, the floors named and a room id'd with the
    payload (and a DEL, a NUL, a C1 control)."""
    return {
        "name": "tower",
        "boundary": [[0, 0], [8, 0], [8, 8], [0, 8]],
        "floors": [{"id": f"f{k}", "name": f"Level {k}{PAYLOAD}\x7f\x85", "rooms": [
            {"id": f"r{j}" + (PAYLOAD[:60] if j == 0 else ""), "type": "office",
             "min_size": [2, 2], "max_size": [6, 6]} for j in range(4)]} for k in range(2)],
        "options": {"time_limit": 20},
    }


@pytest.fixture(scope="module")
def solved(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Server, str]]:
    server = Server(tmp_path_factory.mktemp("dxf"), **QUIET).start()
    try:
        with httpx.Client(base_url=server.url, timeout=60) as client:
            made = client.post("/v1/layouts", json=hostile_building())
            assert made.status_code == 202, made.text
            job = wait(client, made.json()["id"], timeout=180)
            assert job["status"] == "succeeded", job
        yield server, made.json()["id"]
    finally:
        server.stop()


def pairs(text: str) -> list[tuple[int, str]]:
    """The file's (group code, value) pairs; a code line that is not an integer fails."""
    lines = text.splitlines()
    assert len(lines) % 2 == 0
    return [(int(lines[k]), lines[k + 1]) for k in range(0, len(lines), 2)]


@pytest.mark.parametrize("layers", ["ncs", "room-type"])
def test_group_codes_in_names_stay_text(solved: tuple[Server, str], layers: str) -> None:
    server, job_id = solved
    with httpx.Client(base_url=server.url, timeout=60) as client:
        got = client.get(f"/v1/layouts/{job_id}/result",
                         params={"format": "dxf", "dxf_layers": layers})
    assert got.status_code == 200, got.text
    text = got.content.decode()
    found = pairs(text)
    # No value line is the payload's own: the layer names, entity types and
    # coordinates it carries stay inside a longer value.
    layer_names = {value for code, value in found if code == 8}
    assert not any("PWNED" in name for name in layer_names), layer_names
    assert all(value.strip() not in ("PWNED", "PWNEDFLOOR") for _, value in found)
    assert not any(ord(c) < 32 or 127 <= ord(c) < 160
                   for _, value in found for c in value)
    doc = ezdxf.read(io.StringIO(text))
    assert not [layer.dxf.name for layer in doc.layers if "PWNED" in layer.dxf.name]
    spaces = [doc.modelspace(), *doc.blocks]
    assert not [e for space in spaces for e in space if "PWNED" in e.dxf.layer]
    # The names are still there, as text, with spaces for the controls.
    texts = [e.dxf.text for space in spaces for e in space.query("TEXT")]
    texts += [e.text for space in spaces for e in space.query("MTEXT")]
    assert any("PWNEDFLOOR" in t for t in texts), texts
    if layers == "ncs":
        descriptions = [layer.description for layer in doc.layers]
        assert any(d.startswith("Storey Level 0   8 PWNEDFLOOR") for d in descriptions), \
            descriptions
