"""How the command lines write their outputs (`models.formats.write_file`): a regular
file whole or not at all, and never a device, FIFO or symbolic link replaced by one."""

from __future__ import annotations

import os
import stat
import threading
from pathlib import Path

import pytest

from floorplan.models.formats import UnknownFormat, format_of, why_unwritable, write_file


def test_a_regular_file_is_replaced_whole_and_keeps_its_permissions(tmp_path: Path) -> None:
    target = tmp_path / "layout.json"
    target.write_text("old")
    target.chmod(0o640)
    before = target.stat().st_ino
    write_file(str(target), b"new")
    assert target.read_bytes() == b"new"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640
    assert target.stat().st_ino != before  # renamed over, not rewritten
    assert [p.name for p in tmp_path.iterdir()] == ["layout.json"]  # no temporary left


def test_dev_null_stays_a_device() -> None:
    write_file("/dev/null", b"{}")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_a_full_device_fails_and_stays_a_device() -> None:
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full here")
    with pytest.raises(OSError):
        write_file("/dev/full", b"{}")
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)


def test_a_fifo_is_written_in_place(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    write_file(str(fifo), b"layout")
    reader.join(timeout=60)
    assert got == [b"layout"]
    assert stat.S_ISFIFO(fifo.lstat().st_mode)


def test_a_symbolic_link_is_followed_and_stays_a_link(tmp_path: Path) -> None:
    real = tmp_path / "real.json"
    real.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(real)
    write_file(str(link), b"new")
    assert link.is_symlink() and os.readlink(link) == str(real)
    assert real.read_bytes() == b"new"


def test_what_cannot_be_written_is_said_before_any_work(tmp_path: Path) -> None:
    assert why_unwritable(str(tmp_path / "missing" / "x.json")) == (
        f"{tmp_path / 'missing' / 'x.json'}: directory {tmp_path / 'missing'} does not exist")
    assert why_unwritable(str(tmp_path)) == f"{tmp_path}: is a directory"
    assert why_unwritable("/dev/null") is None
    assert why_unwritable("-") is None


def test_an_unknown_extension_names_no_format() -> None:
    assert format_of("PLAN.IFC") == "ifc" and format_of("/dev/stdout") == "json"
    with pytest.raises(UnknownFormat, match=r"\.pdf"):
        format_of("plan.pdf")
