"""Edits around fixed rooms: ``python -m bench edits`` (bench/NOTES.md, "Edits around
fixed rooms").

    python -m bench edits [--cases DIR] [--only NAME ...] [--per-case N]
                          [--via service|solver] [--no-start] [--out DIR]

For each case (default: the cases of bench/data/cases of 8 to 60 rooms), the first layout is
solved in-process (not timed). Each edit then takes one room with a target and the
three rooms sharing the longest walls with it as the free rooms, fixes every other
room at its polygon of the first layout, and scales the free room's target by 0.9
(even edits) or 1.1 (odd ones) per side, within its size bounds. The edited brief
carries the first layout as `options.start` unless ``--no-start``.

``--via service`` (the default) starts ``python -m floorplan.service serve`` on a loopback port
(the embedded mode, its default settings), sends one edit first to warm it (not
counted), and times each edit from the POST to the poll that sees it succeeded (the
job polled every `POLL_SECONDS`), the result fetched after the clock stops.
``--via solver`` times `solver.solve` in this process instead. Every result is
checked: valid (the solver's independent checker, as the report gives it), and each
fixed room's polygon at most `KEPT_TOLERANCE` m from the one asked (Hausdorff
distance). Writes results.json and results.md in ``--out``. bench may not import
service: the server is a child process, reached over HTTP.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import httpx2 as httpx
import shapely
from shapely.geometry import Polygon

from floorplan.models import Layout, Problem

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "bench" / "data" / "cases"
#: Cases with fewer rooms cannot fix most of them around four free ones; larger ones
#: take minutes for their first layout.
MIN_ROOMS, MAX_ROOMS = 8, 60
#: The free room and this many neighbours stay free.
NEIGHBOURS = 3
#: Per side, the edited target is the old one times these, in turn.
FACTORS = (0.9, 1.1)
#: How far (m) a fixed room's polygon may lie from the one asked.
KEPT_TOLERANCE = 1e-4
#: The bound an edit's round trip should keep (seconds): an edit is interactive.
ROUND_TRIP_GOAL = 1.5
POLL_SECONDS = 0.01
DEFAULT_OUT = ROOT / "bench" / "results" / "edits"


@dataclass(frozen=True)
class Edit:
    case: str
    room: str
    factor: float
    free: tuple[str, ...]
    brief: dict[str, Any]


@dataclass(frozen=True)
class EditRecord:
    case: str
    room: str
    factor: float
    free: tuple[str, ...]
    seconds: float
    status: str
    valid: bool
    coverage: float
    fixed_kept: bool
    worst_fixed_offset: float
    termination: str


def first_layouts(cases: dict[str, Problem]) -> dict[str, Layout]:
    from floorplan.solver import solve

    return {name: solve(problem) for name, problem in cases.items()}


def neighbours(layout: Layout, room_id: str) -> list[str]:
    """The rooms of `layout` by the length of wall they share with `room_id`, longest
    first (those touching it only)."""
    polygons = {r.id: Polygon(r.polygon) for r in layout.rooms}
    mine = polygons[room_id].boundary
    shared = {r: float(mine.intersection(p.boundary).length) for r, p in polygons.items()
              if r != room_id}
    return [r for r, length in sorted(shared.items(), key=lambda kv: (-kv[1], kv[0]))
            if length > 1e-6]


def make_edits(name: str, problem: Problem, layout: Layout, count: int, *,
               start: bool = True) -> list[Edit]:
    """`count` edits of `layout`: a room with a target in turn, free with its
    `NEIGHBOURS` nearest, the others fixed, the target scaled by `FACTORS` in turn."""
    polygons = {r.id: [list(p) for p in r.polygon] for r in layout.rooms}
    with_target = [room for room in problem.rooms if room.target_size is not None]
    edits = []
    for k in range(min(count, len(with_target))):
        room = with_target[k * len(with_target) // count]
        factor = FACTORS[k % len(FACTORS)]
        free = (room.id, *neighbours(layout, room.id)[:NEIGHBOURS])
        brief = problem.model_dump(mode="json", exclude_none=True)
        for data in brief["rooms"]:
            if data["id"] not in free:
                data["fixed"] = polygons[data["id"]]
            elif data["id"] == room.id:
                lo = room.min_size or (0.0, 0.0)
                hi = room.max_size or (1e9, 1e9)
                data["target_size"] = [min(max(t * factor, lo[i]), hi[i])
                                       for i, t in enumerate(room.target_size or ())]
        if start:
            brief.setdefault("options", {})["start"] = [
                {"id": r.id, "rectangles": [rect.model_dump() for rect in r.rectangles]}
                for r in layout.rooms]
        edits.append(Edit(name, room.id, factor, free, brief))
    return edits


def fixed_offset(edit: Edit, layout: Layout) -> float:
    """The largest Hausdorff distance (m) between a fixed room's polygon as asked and
    as answered (infinite when the room is missing)."""
    asked = {r["id"]: Polygon(r["fixed"]) for r in edit.brief["rooms"] if "fixed" in r}
    got = {r.id: Polygon(r.polygon) for r in layout.rooms}
    worst = 0.0
    for room_id, polygon in asked.items():
        if room_id not in got:
            return float("inf")
        worst = max(worst, float(shapely.hausdorff_distance(polygon, got[room_id])))
    return worst


def record(edit: Edit, seconds: float, status: str, layout: Layout | None) -> EditRecord:
    offset = fixed_offset(edit, layout) if layout is not None else float("inf")
    return EditRecord(
        edit.case, edit.room, edit.factor, edit.free, round(seconds, 4), status,
        valid=layout is not None and layout.report.valid,
        coverage=layout.report.coverage if layout is not None else 0.0,
        fixed_kept=offset <= KEPT_TOLERANCE, worst_fixed_offset=offset,
        termination=str(layout.report.termination) if layout is not None else "",
    )


def run_solver(edits: list[Edit]) -> list[EditRecord]:
    from floorplan.solver import solve

    records = []
    for edit in edits:
        problem = Problem.model_validate(edit.brief)
        started = time.monotonic()
        layout = solve(problem)
        records.append(record(edit, time.monotonic() - started, "succeeded", layout))
    return records


class Service:
    """``python -m floorplan.service serve`` on a free loopback port, in its own directory."""

    def __init__(self, data_dir: Path) -> None:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = int(s.getsockname()[1])
        self.url = f"http://127.0.0.1:{self.port}"
        self.process = subprocess.Popen(
            [sys.executable, "-m", "floorplan.service", "serve", "--port", str(self.port),
             "--data-dir", str(data_dir), "--log-level", "warning"],
            env=dict(os.environ), start_new_session=True,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                if httpx.get(f"{self.url}/readyz", timeout=1).status_code == 200:
                    return
            except httpx.TransportError:
                pass
            if self.process.poll() is not None:
                raise RuntimeError(f"the service exited with {self.process.returncode}")
            time.sleep(0.1)
        self.stop()
        raise RuntimeError("the service did not become ready within 60 s")

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()

    def edit(self, client: httpx.Client, edit: Edit) -> tuple[float, str, Layout | None]:
        """One round trip: POST, poll until the job ends; then its result."""
        started = time.monotonic()
        reply = client.post(f"{self.url}/v1/layouts", json=edit.brief)
        reply.raise_for_status()
        job = reply.json()
        while job["status"] not in ("succeeded", "failed", "canceled"):
            time.sleep(POLL_SECONDS)
            job = client.get(f"{self.url}/v1/layouts/{job['id']}").json()
        seconds = time.monotonic() - started
        layout = None
        if job["status"] == "succeeded":
            result = client.get(f"{self.url}/v1/layouts/{job['id']}/result")
            layout = Layout.model_validate_json(result.content)
        return seconds, job["status"], layout


def run_service(edits: list[Edit]) -> list[EditRecord]:
    with tempfile.TemporaryDirectory(prefix="bench-edits-") as data:
        service = Service(Path(data))
        try:
            with httpx.Client(timeout=60) as client:
                service.edit(client, edits[0])  # warm: the first solve process starts
                return [record(edit, *service.edit(client, edit)) for edit in edits]
        finally:
            service.stop()


def summary(records: list[EditRecord]) -> dict[str, Any]:
    seconds = [r.seconds for r in records]
    return {
        "edits": len(records),
        "median_seconds": round(statistics.median(seconds), 3),
        "max_seconds": round(max(seconds), 3),
        "within_goal": sum(s <= ROUND_TRIP_GOAL for s in seconds),
        "valid": sum(r.valid for r in records),
        "fixed_kept": sum(r.fixed_kept for r in records),
    }


def markdown(settings: dict[str, Any], records: list[EditRecord]) -> str:
    s = summary(records)
    lines = [
        "# Edits around fixed rooms", "",
        f"`python -m bench edits` via {settings['via']}, start "
        f"{'given' if settings['start'] else 'not given'}, {settings['machine']}.", "",
        f"{s['edits']} edits: median round trip {s['median_seconds']:.3f} s, max "
        f"{s['max_seconds']:.3f} s, {s['within_goal']} within {ROUND_TRIP_GOAL} s; "
        f"{s['valid']} valid; fixed rooms kept to {KEPT_TOLERANCE} m in {s['fixed_kept']}.",
        "", "| case | room | target | free rooms | seconds | valid | coverage | fixed kept "
        "(worst offset, m) | termination |", "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        lines.append(
            f"| {r.case} | {r.room} | x{r.factor:g} | {', '.join(r.free)} | {r.seconds:.3f} "
            f"| {'yes' if r.valid else 'no'} | {r.coverage:.1%} | "
            f"{'yes' if r.fixed_kept else 'no'} ({r.worst_fixed_offset:.1e}) | "
            f"{r.termination or r.status} |")
    return "\n".join(lines) + "\n"


def load_cases(directory: Path, only: list[str] | None) -> dict[str, Problem]:
    cases = {}
    for path in sorted(directory.glob("*.json")):
        if only is not None and path.stem not in only:
            continue
        problem = Problem.model_validate_json(path.read_text(encoding="utf-8"))
        if only is not None or MIN_ROOMS <= len(problem.rooms) <= MAX_ROOMS:
            cases[path.stem] = problem
    return cases


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m bench edits", description=(
        "Edits of first layouts around fixed rooms: round-trip time, validity and "
        "fixed rooms kept."))
    p.add_argument("--cases", type=Path, default=CASES)
    p.add_argument("--only", nargs="+", default=None, metavar="NAME")
    p.add_argument("--per-case", type=int, default=5, help="edits per case")
    p.add_argument("--via", choices=("service", "solver"), default="service")
    p.add_argument("--no-start", action="store_true",
                   help="send the edits without the first layout as options.start")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = p.parse_args(argv)
    cases = load_cases(args.cases, args.only)
    if not cases:
        print(f"no cases in {args.cases}", file=sys.stderr)
        return 2
    print(f"first layouts of {', '.join(cases)} ...", file=sys.stderr, flush=True)
    layouts = first_layouts(cases)
    edits = [e for name, problem in cases.items()
             for e in make_edits(name, problem, layouts[name], args.per_case,
                                 start=not args.no_start)]
    records = run_service(edits) if args.via == "service" else run_solver(edits)
    settings = {"via": args.via, "start": not args.no_start, "cases": list(cases),
                "per_case": args.per_case,
                "machine": f"{os.cpu_count()} cores, {sys.platform}",
                "first_layouts": {n: {"valid": lay.report.valid,
                                      "coverage": lay.report.coverage}
                                  for n, lay in layouts.items()}}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps(
        {"settings": settings, "summary": summary(records),
         "edits": [asdict(r) for r in records]}, indent=1), encoding="utf-8")
    (args.out / "results.md").write_text(markdown(settings, records), encoding="utf-8")
    print(markdown(settings, records))
    return 0
