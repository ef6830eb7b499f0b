"""What `floorplan solve` prints on stderr: a line per solver event (`ProgressPrinter`,
incumbents throttled), a one-line summary, and what is wrong with the layout or why
there is none. Standard library only at import time, as service/cli/solve.py needs."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, TextIO

from floorplan.service.cli.exits import PROG

if TYPE_CHECKING:
    from floorplan.models import Layout
    from floorplan.solver.events import SolveEvent

#: Least seconds between two printed INCUMBENT events (other events are always printed).
INCUMBENT_INTERVAL = 0.25
#: `solver.events.Phase.INCUMBENT` (a StrEnum), spelt out to keep the solver import lazy.
INCUMBENT = "incumbent"


class ProgressPrinter:
    """An `on_event` sink printing one line per event, incumbents throttled.

    An incumbent that came too soon after the last printed one is held back and
    printed before the next other event, so each MIQP's last incumbent shows."""

    def __init__(self, stream: TextIO, interval: float = INCUMBENT_INTERVAL,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream
        self.interval = interval
        self.clock = clock
        self._last_incumbent = -math.inf
        self._held: SolveEvent | None = None

    def __call__(self, event: SolveEvent) -> None:
        if event.phase == INCUMBENT:
            now = self.clock()
            if now - self._last_incumbent < self.interval:
                self._held = event
                return
            self._last_incumbent = now
        elif self._held is not None:
            self._print(self._held)
        self._held = None
        self._print(event)

    def _print(self, event: SolveEvent) -> None:
        print(progress_line(event), file=self.stream, flush=True)


def progress_line(event: SolveEvent) -> str:
    """E.g. ``[  1.23s] level 2 sub 1/3  obj 12.41  bound 3.20  rooms a, b: optimal``."""
    # Here, not at the top: this module loads before the Ctrl-C handling, and the
    # contract's modules bring pydantic; an event means the solver is loaded already.
    from floorplan.models.jobs import format_number

    parts = [f"[{event.elapsed:6.2f}s] level {event.level}"]
    if event.subdomains:
        parts[0] += f" sub {event.subdomain}/{event.subdomains}"
    if event.objective is not None:
        parts.append(f"obj {format_number(event.objective)}")
    if event.dual_bound is not None:
        parts.append(f"bound {format_number(event.dual_bound)}")
    detail = event.detail.removeprefix(f"level {event.level}: ")  # said already
    parts.append(detail or ("new incumbent" if event.phase == INCUMBENT else event.phase))
    return "  ".join(parts)


def summary_line(layout: Layout) -> str:
    r = layout.report
    soft = (f"  soft violations {len(r.violations)} ({r.total_shortfall:.2f} m short)"
            if r.violations else "")
    floors = f" on {len(layout.floors)} floors" if layout.floors is not None else ""
    return (f"{len(layout.all_rooms)} rooms{floors}  coverage {r.coverage:.1%}  "
            f"levels {r.levels}  termination {r.termination.value}  "
            f"valid {'yes' if r.valid else 'no'}{soft}  solve time {r.solve_time:.2f} s")


def invalid_layout_warning(layout: Layout) -> str:
    failed = [c for c in layout.report.constraints if not c.satisfied]
    lines = [f"{PROG}: warning: the layout fails {len(failed)} check(s):"]
    for c in failed:
        rooms = ", ".join(c.rooms)
        lines.append(f"  {c.kind}{' ' + rooms if rooms else ''}"
                     f"{' on floor ' + c.floor if c.floor else ''}"
                     f"{': ' + c.detail if c.detail else ''}")
    return "\n".join(lines)


def soft_violations_note(layout: Layout) -> str:
    """The soft constraints a valid layout breaks, each with its shortfall."""
    r = layout.report
    lines = [f"{PROG}: {len(r.violations)} soft constraint(s) not met, "
             f"{r.total_shortfall:.2f} m short in all:"]
    for c in r.violations:
        lines.append(f"  {c.kind} {', '.join(c.rooms)}: {c.shortfall:.2f} m short"
                     f"{' (' + c.detail + ')' if c.detail else ''}")
    return "\n".join(lines)


def no_layout_message(layout: Layout) -> str:
    r = layout.report
    why = r.infeasibility
    lines = [f"{PROG}: no layout ({r.termination.value}): "
             f"{why.reason if why else 'no reason given'}"]
    if why is not None:
        if why.conflict is not None:
            lines.append(f"  {why.conflict.explanation}")
            lines += _section("constraints in conflict", [
                f"{c.path}: {c.constraint}" for c in why.conflict.constraints])
        lines += _section("findings", why.findings)
        lines += _section("relaxations tried", why.relaxations_tried)
        lines += _section("constraint families", why.active_families)
    return "\n".join(lines)


def _section(title: str, items: Sequence[str]) -> list[str]:
    return [f"  {title}:", *(f"    - {item}" for item in items)] if items else []
