"""The `floorplan` command's name, which begins its messages, and its exit codes."""

PROG = "floorplan"

EXIT_OK = 0
"""A layout with rooms was written (it may still fail checks: see the warning; a
Ctrl-C may have cut the solve short: see ``report.termination``)."""
EXIT_FAILURE = 1
"""The output could not be written."""
EXIT_INVALID = 2
"""Bad arguments or an invalid problem; nothing was solved."""
EXIT_NO_LAYOUT = 3
"""No layout: infeasible, or no solution within the time limit. The JSON report says why."""
EXIT_INTERRUPTED = 130
"""Stopped by Ctrl-C before there was a layout, or aborted by a second one
(128 + SIGINT, the shell's convention)."""
