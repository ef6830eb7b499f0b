"""Ctrl-C for `floorplan solve`: the first one stops the solve gracefully (the best
layout so far is written), a second one aborts at once; see `sigint_flag`. Standard
library only at import time, as service/cli/solve.py needs."""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from types import FrameType

from floorplan.service.cli.exits import EXIT_INTERRUPTED, PROG


@contextmanager
def sigint_flag() -> Iterator[Callable[[], bool]]:
    """Within the block the first SIGINT only sets a flag (read it with the yielded
    function, a `should_stop` for `solve`); a second one aborts the process at once.

    SCIP installs its own SIGINT handler while it optimises (misc/catchctrlc): it ends
    the current MIQP only, and a Python handler never hears of the signal, so the solve
    would go on with the next one. Hence SIGINT is blocked in this thread (and in the
    threads it starts) and a watcher thread takes it with ``sigwait``: no handler, ours
    or SCIP's, ever runs. Where ``pthread_sigmask`` is missing a plain handler does.

    Threads started before the block keep SIGINT unblocked and may take it (numpy's
    OpenBLAS starts some on import): enter it before the solver is imported."""
    if threading.current_thread() is not threading.main_thread():
        yield lambda: False  # signals reach the main thread only; leave them alone
        return
    if not hasattr(signal, "pthread_sigmask"):
        with _sigint_handler() as received:
            yield received
        return
    watcher = _SigintWatcher()
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        watcher.start()
        yield watcher.received
    finally:
        watcher.stop()
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def keep_sigint_blocked() -> None:
    """Block SIGINT in this thread again, within `sigint_flag`. Starting a process pool
    starts multiprocessing's resource tracker, which unblocks SIGINT in the calling
    thread once the tracker runs; SCIP's handler or a KeyboardInterrupt would then
    take the next Ctrl-C instead of the watcher."""
    if threading.current_thread() is threading.main_thread() and hasattr(
            signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


class _SigintWatcher:
    """A daemon thread waiting for SIGINT with ``sigwait`` (see `sigint_flag`)."""

    def __init__(self) -> None:
        self._received = False
        self._closing = False
        self._thread = threading.Thread(target=self._watch, name="sigint-watcher", daemon=True)

    def received(self) -> bool:
        return self._received

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._closing = True
        if self._thread.ident is not None and self._thread.is_alive():
            with suppress(OSError):  # it may have just taken a last real SIGINT and ended
                signal.pthread_kill(self._thread.ident, signal.SIGINT)
        self._thread.join()

    def _watch(self) -> None:
        while True:
            signal.sigwait({signal.SIGINT})
            if self._closing:
                return
            if self._received:
                print(f"{PROG}: aborted", file=sys.stderr, flush=True)
                os._exit(EXIT_INTERRUPTED)
            self._received = True
            print(f"{PROG}: stopping; the best layout so far will be written "
                  "(Ctrl-C again to abort)", file=sys.stderr, flush=True)


@contextmanager
def _sigint_handler() -> Iterator[Callable[[], bool]]:
    received = False

    def handler(_signum: int, _frame: FrameType | None) -> None:
        nonlocal received
        if received:
            raise KeyboardInterrupt
        received = True

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield lambda: received
    finally:
        signal.signal(signal.SIGINT, previous)
