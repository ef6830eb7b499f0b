"""The exit codes of ``floorplan submit`` (the same as ``floorplan solve``'s), the
command's name in its messages, and the error for input refused before anything is
sent."""

from __future__ import annotations

EXIT_OK = 0
"""A layout was written (after a Ctrl-C too: ``report.termination`` is then
``interrupted``), or, without ``--wait``, the job was queued."""
EXIT_FAILURE = 1
"""The service could not be reached or failed, or the output could not be written."""
EXIT_INVALID = 2
"""Bad arguments, an unreadable problem file, or a problem the service refused."""
EXIT_NO_LAYOUT = 3
"""The job ended without a layout: infeasible, or nothing found in the time limit."""
EXIT_INTERRUPTED = 130
"""Ctrl-C before the job had a layout, or a second Ctrl-C."""

PROG = "floorplan"


class UsageError(Exception):
    """Input refused before anything is sent; the message is shown as is."""
