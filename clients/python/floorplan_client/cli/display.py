"""``floorplan submit``'s messages and its progress display: a summary line, why a job
has no layout, and the job's progress as rich's live line, plain lines or nothing."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol, TextIO

from floorplan_client.cli.exits import EXIT_FAILURE, EXIT_INVALID, PROG

if TYPE_CHECKING:
    from rich.console import Console

    from floorplan_client import Event, Job
    from floorplan_client.models import Layout

#: Least seconds between two plain progress lines (status changes always print).
PLAIN_INTERVAL = 0.5


class Say:
    """Prints a line to stderr unless quiet."""

    def __init__(self, stream: TextIO, *, quiet: bool) -> None:
        self.stream = stream
        self.quiet = quiet

    def __call__(self, text: str) -> None:
        if not self.quiet:
            print(text, file=self.stream, flush=True)


def submit_failed(problem: str, err: Exception) -> int:
    """Report a submission the service refused or could not take; the exit code."""
    from floorplan_client import InvalidProblem

    if isinstance(err, InvalidProblem):
        lines = "\n".join(f"  {e}" for e in err.errors) or f"  {err.problem.detail}"
        print(f"{PROG}: error: {problem}: the service refused the problem\n{lines}",
              file=sys.stderr)
        return EXIT_INVALID
    print(f"{PROG}: error: {err}", file=sys.stderr)
    return EXIT_FAILURE


def summary_line(job: Job, layout: Layout) -> str:
    """E.g. ``2 rooms  coverage 100.0%  termination optimal  valid yes  job 1f0c...``;
    with corridors, what they take and how far people walk (``corridors 25.1%  longest
    walk 42.3 m  routes 36.0 m``: each route's walk, ``none`` where no corridor joins
    its points)."""
    r = layout.report
    egress = ""
    if r.egress is not None:
        egress = f"corridors {r.egress.corridor_share:.1%}  "
        if r.egress.max_travel is not None:
            egress += f"longest walk {r.egress.max_travel:.1f} m  "
        if r.egress.routes:
            walks = ", ".join("none" if w is None else f"{w:.1f}" for w in r.egress.routes)
            egress += f"routes {walks} m  "
    return (f"{len(layout.all_rooms)} rooms  coverage {r.coverage:.1%}  {egress}"
            f"termination {r.termination.value}  valid {'yes' if r.valid else 'no'}  "
            f"job {job.id}")


def no_layout_message(err: Any) -> str:
    """Why a job ended without a layout, with the findings, one per line."""
    lines = [f"{PROG}: no layout ({err.code}): {err.message}"]
    conflict = err.job.error.conflict if err.job.error else None
    if conflict is not None:
        lines += [f"  {conflict.explanation}", "  constraints in conflict:",
                  *(f"    - {c.path}: {c.constraint}" for c in conflict.constraints)]
    findings = list(err.job.error.findings) if err.job.error else []
    if findings:
        lines += ["  findings:", *(f"    - {f}" for f in findings)]
    return "\n".join(lines)


class JobState:
    """What the display shows, from the events seen so far."""

    def __init__(self) -> None:
        self.status = "queued"
        self.level: int | None = None
        self.subdomain: int | None = None
        self.subdomains: int | None = None
        self.objective: float | None = None

    def update(self, event: Event) -> None:
        """Take in one event."""
        from floorplan_client.types import IncumbentEvent, StatusEvent

        if isinstance(event, StatusEvent):
            self.status = event.status.value
            return
        progress = event.progress
        if progress.level is not None:
            self.level = progress.level
            self.subdomain, self.subdomains = progress.subdomain, progress.subdomains
        if isinstance(event, IncumbentEvent):
            objective = progress.objective if progress.objective is not None \
                else event.layout.report.objective
            if objective is not None:
                self.objective = objective
        elif progress.objective is not None:
            self.objective = progress.objective

    def where(self) -> str:
        """E.g. ``running  level 2 sub 1/3``."""
        text = self.status
        if self.level is not None:
            text += f"  level {self.level}"
            if self.subdomains:
                text += f" sub {self.subdomain}/{self.subdomains}"
        return text

    def objective_text(self) -> str:
        """E.g. ``objective 12.41``; "" before the first incumbent."""
        from floorplan_client.models.jobs import format_number

        return "" if self.objective is None else f"objective {format_number(self.objective)}"


class Display(Protocol):
    """Shows a job's progress while it runs."""

    def update(self, event: Event) -> None:
        """Take in one event."""

    def close(self) -> None:
        """The job has ended (or the wait was cut short): stop showing."""


class NullDisplay:
    """Shows nothing (``--quiet``)."""

    def update(self, event: Event) -> None:
        """Ignore the event."""

    def close(self) -> None:
        """Nothing to stop."""


class PlainDisplay:
    """One line per event on a stream: every status, progress at most every
    `PLAIN_INTERVAL` seconds. For logs, and where rich is not installed."""

    def __init__(self, stream: TextIO, interval: float = PLAIN_INTERVAL,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream
        self.interval = interval
        self.clock = clock
        self.state = JobState()
        self._started = clock()
        self._last = -math.inf

    def update(self, event: Event) -> None:
        """Take in one event; print a line unless one was printed moments ago."""
        self.state.update(event)
        now = self.clock()
        if event.kind != "status" and now - self._last < self.interval:
            return
        self._last = now
        parts = [f"[{now - self._started:6.1f}s] {self.state.where()}",
                 self.state.objective_text()]
        print("  ".join(p for p in parts if p), file=self.stream, flush=True)

    def close(self) -> None:
        """Nothing to stop."""


class RichDisplay:
    """A live line on a terminal: spinner, status, level, sub-domain, incumbent
    objective and elapsed time (rich's progress display)."""

    def __init__(self, console: Console | None = None) -> None:
        from rich.console import Console
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        self.state = JobState()
        self._progress = Progress(
            SpinnerColumn(), TextColumn("{task.description}"),
            TextColumn("{task.fields[objective]}"), TimeElapsedColumn(),
            console=console or Console(stderr=True), transient=False,
        )
        self._task = self._progress.add_task(self.state.where(), total=None, objective="")
        self._progress.start()

    def update(self, event: Event) -> None:
        """Take in one event and redraw."""
        self.state.update(event)
        self._progress.update(self._task, description=self.state.where(),
                              objective=self.state.objective_text())

    def close(self) -> None:
        """Stop the live line, leaving its last state on the screen."""
        self._progress.stop()


def make_display(*, quiet: bool, stream: TextIO | None = None) -> Display:
    """Rich's live line on a terminal when rich is installed, plain lines otherwise,
    nothing when quiet."""
    stream = stream or sys.stderr
    if quiet:
        return NullDisplay()
    if stream.isatty():
        try:
            return RichDisplay()
        except ImportError:
            pass
    return PlainDisplay(stream)
