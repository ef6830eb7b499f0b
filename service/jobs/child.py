"""What runs inside a solve's own process: the solver, reporting back over a queue.

Started with `spawn`, never `fork` (SCIP and threads do not survive a fork), so this
module is imported afresh in the child and must stay light at import time.

The one Celery piece a solve may need, the sub-domain executor, is imported only when
it asks for it, from service/jobs/broker/subdomains.py, which imports nothing of the
backends, the runner or this module.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import Executor, ProcessPoolExecutor
from multiprocessing.connection import Connection
from multiprocessing.queues import Queue
from multiprocessing.synchronize import Event
from typing import Any

#: Seconds a standby process waits between looks at whether its parent still lives.
STANDBY_POLL = 1.0
#: Seconds a solved layout waits for the batch's plans it must differ from.
HELD_WAIT = 10.0
#: Seconds between two incumbent layouts sent to the parent: building one costs
#: geometry, and the event stream shows at most two a second anyway.
INCUMBENT_INTERVAL = 0.5


def subdomain_executor(processes: int, remote: bool) -> tuple[Executor | None, int]:
    """Where this solve's independent sub-domains go, and how many at once: Celery tasks
    for the sub-domain workers (`remote`, while any is alive), else a local pool of
    `processes` (None for one: one after the other)."""
    if remote:
        from floorplan.service.jobs.broker.subdomains import subdomain_executor as celery_executor
        from floorplan.service.settings import get_settings

        executor = celery_executor(get_settings())
        if executor is not None:
            return executor, executor.slots
    from floorplan.solver.pipeline.pool import subdomain_pool

    return subdomain_pool(processes), processes


def end_executor(executor: Executor | None) -> None:
    if isinstance(executor, ProcessPoolExecutor):
        from floorplan.solver.pipeline.pool import end_pool

        end_pool(executor)
    elif executor is not None:
        executor.shutdown(wait=False, cancel_futures=True)


def run_job(
    problem_json: str, messages: Queue[tuple[str, Any]], stop: Event, parent: int,
    subdomain_processes: int = 1, subdomain_tasks: bool = False,
    warm_pool: ProcessPoolExecutor | None = None, jobs: Connection | None = None,
) -> None:
    """Solve and send ("progress", dict), ("incumbent", (dict, layout_json)) and
    finally ("done", layout_json); an exception is sent as ("error", message).
    The solve stops when `stop` is set or the parent process `parent` is gone (a
    killed service must not leave orphans running). The sub-domains of a refinement
    level are solved at once as Celery tasks with `subdomain_tasks`, else in a pool of
    `subdomain_processes` when that is more than one: `warm_pool` if one was started
    ahead (`standby`), else one started now. A diverse layout that stops when good (a
    batch's) asks the parent, on `jobs`, for the layouts its batch has finished by now
    and, when its plan is one of theirs, has its walls moved apart from them, or is laid
    out again under another draw (service.batch.apart_from_held)."""

    def should_stop() -> bool:
        return stop.is_set() or os.getppid() != parent

    pool: Executor | None = warm_pool
    try:
        from floorplan.models import Problem
        from floorplan.solver import solve
        from floorplan.solver.events import Phase, SolveEvent
        from floorplan.solver.pipeline.assemble import draft_layout
        from floorplan.solver.pipeline.subdomains import SubdomainExecutor

        problem = Problem.model_validate_json(problem_json)
        if warm_pool is None:
            pool, slots = subdomain_executor(subdomain_processes, subdomain_tasks)
        else:
            slots = subdomain_processes
        last_incumbent = 0.0

        def on_event(e: SolveEvent) -> None:
            nonlocal last_incumbent
            progress = {
                "phase": e.phase.value, "level": e.level, "subdomain": e.subdomain,
                "subdomains": e.subdomains, "objective": e.objective,
                "dual_bound": e.dual_bound, "elapsed": round(e.elapsed, 3), "detail": e.detail,
            }
            if e.phase is Phase.INCUMBENT:
                now = time.monotonic()
                if e.rooms is None or now - last_incumbent < INCUMBENT_INTERVAL:
                    return
                last_incumbent = now
                layout = draft_layout(problem, e.rooms, e.objective, floor=e.floor)
                messages.put(("incumbent", (progress, layout.model_dump_json())))
            else:
                messages.put(("progress", progress))

        subdomains = SubdomainExecutor(pool, slots) if pool is not None else None
        layout = solve(problem, on_event=on_event, should_stop=should_stop,
                       subdomains=subdomains)
        if (jobs is not None and problem.options.diverse and problem.options.stop_when_good
                and problem.floors is None and not problem.by_regions and not should_stop()):
            # (A floor of regions, or of several storeys, is not moved apart: whole wall
            # lines cross its aisles and floors, and its layouts are large to send.)
            from floorplan.service.batch import apart_from_held

            end_executor(pool)  # a second search still running would slow the redraw
            pool = None

            layout, done = apart_from_held(
                problem, layout, _held(messages, jobs),
                again=lambda redrawn: solve(redrawn, should_stop=should_stop))
            if done is not None:
                messages.put(("progress", {"phase": Phase.DONE.value, "detail": done}))
        # The answer first: ending the pool (killing and reaping its processes) takes
        # a while on a busy machine, and the user is waiting for the layout.
        messages.put(("done", layout.model_dump_json()))
        end_executor(pool)
    except Exception as err:
        end_executor(pool)
        messages.put(("error", f"{type(err).__name__}: {err}"))


def _held(messages: Queue[tuple[str, Any]], jobs: Connection) -> list[str]:
    """The plans the parent says this layout must differ from (none if it does not
    answer within `HELD_WAIT`)."""
    messages.put(("held", None))
    try:
        if jobs.poll(HELD_WAIT):
            return list(jobs.recv())
    except (EOFError, OSError):
        pass
    return []


def standby(
    jobs: Connection, messages: Queue[tuple[str, Any]], stop: Event, parent: int,
    subdomain_processes: int = 1, subdomain_tasks: bool = False,
) -> None:
    """A solve process started ahead of its job: pay for the imports (SCIP, shapely)
    now, then wait for one problem, solve it and exit, as every solve has its own
    process. Gives up if the parent goes away first, or closes the pipe without a job."""
    import floorplan.solver.pipeline.dispatch  # noqa: F401 - warming up is the point

    # A local pool starts now too, so that its processes have imported SCIP when the job
    # comes: a second level-1 search that starts a second late rarely ends better
    # (bench/NOTES.md, "A restart alone, error-centred neighbourhoods, and the hall's
    # floor"). Celery sub-domain workers are chosen when the job comes.
    pool = None
    if subdomain_processes > 1 and not subdomain_tasks:
        from floorplan.solver.pipeline.pool import subdomain_pool

        pool = subdomain_pool(subdomain_processes)
    while not jobs.poll(STANDBY_POLL):
        if os.getppid() != parent:
            end_executor(pool)
            return
    try:
        problem_json = jobs.recv()
    except EOFError:  # the service closed the pipe: no job will come
        end_executor(pool)
        return
    run_job(problem_json, messages, stop, parent, subdomain_processes, subdomain_tasks,
            warm_pool=pool, jobs=jobs)
