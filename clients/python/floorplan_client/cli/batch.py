"""``floorplan submit --count N``: a batch queued, followed, and its layouts written."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from floorplan_client.cli.display import Say, submit_failed
from floorplan_client.cli.exits import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    EXIT_NO_LAYOUT,
    EXIT_OK,
    PROG,
    UsageError,
)
from floorplan_client.cli.files import load_problem

#: Seconds between two looks at a batch's progress while following it.
BATCH_POLL = 1.0


def submit_batch(args: argparse.Namespace) -> int:
    """``floorplan submit --count N``: queue a batch, and with --wait or --out follow it
    (a progress line per change) and write its layouts."""
    from floorplan_client import NOT_GIVEN, Client, FloorplanError

    if args.count < 1:
        raise UsageError("--count: at least 1")
    if args.output is not None or args.svg is not None:
        raise UsageError("a batch writes to --out DIR, not -o or --svg")
    problem = load_problem(args.problem)
    say = Say(sys.stderr, quiet=args.quiet)
    api_key = NOT_GIVEN if args.api_key is None else args.api_key
    with Client(args.server, api_key=api_key) as fp:
        try:
            batch = fp.submit_batch(problem, args.count, seed=args.seed or 0,
                                    time_limit=args.time_limit,
                                    vary_program=args.vary == "program")
        except FloorplanError as err:
            return submit_failed(args.problem, err)
        print(batch.id, flush=True)
        say(f"{PROG}: batch {batch.id} of {batch.count} layouts queued on {fp.base_url}")
        if not (args.wait or args.out):
            return EXIT_OK
        try:
            shown = None
            while not batch.status.terminal:
                time.sleep(BATCH_POLL)
                batch = fp.get_batch(batch.id)
                line = (f"{batch.succeeded + batch.failed + batch.canceled}/{batch.count} done, "
                        f"{batch.running} running, {batch.failed} failed")
                if line != shown:
                    say(f"{PROG}: {line}")
                    shown = line
            batch = fp.get_batch(batch.id, summary=True)
            say(f"{PROG}: batch {batch.status.value}: {batch.valid} valid, "
                f"{batch.distinct_plans} distinct plans, {batch.distinct_graphs} adjacency "
                "graphs")
            if args.out:
                out = Path(args.out)
                out.mkdir(parents=True, exist_ok=True)
                for line in fp.batch_results(batch.id):
                    if line.layout is not None:
                        target = out / f"{batch.name}-{line.seed:06d}.json"
                        target.write_text(line.layout.model_dump_json(indent=2) + "\n",
                                          encoding="utf-8")
        except FloorplanError as err:
            print(f"{PROG}: error: batch {batch.id}: {err}", file=sys.stderr)
            return EXIT_FAILURE
        except KeyboardInterrupt:
            fp.cancel_batch(batch.id)
            print(f"{PROG}: canceled the rest of batch {batch.id}", file=sys.stderr)
            return EXIT_INTERRUPTED
    return EXIT_OK if batch.failed == 0 else EXIT_NO_LAYOUT
