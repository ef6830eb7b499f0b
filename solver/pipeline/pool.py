"""A local pool of spawned processes for one solve's sub-domains and second level-1
search (`solver.pipeline.subdomains`), for the command line and the service's solve
processes: started warm, ended at once, and never outliving the process that owns it."""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from concurrent.futures import ProcessPoolExecutor, wait

#: Seconds between a pool process's looks at whether the process that started it lives.
PARENT_POLL = 0.5
#: Seconds to wait for a killed pool to be reaped: a SIGKILL takes effect at once, so
#: this bounds only a wedged manager thread.
END_POOL_SECONDS = 5.0


def subdomain_pool(processes: int, *, warmed: bool = False) -> ProcessPoolExecutor | None:
    """A pool of `processes` spawned processes for one solve (None for one: sub-domains
    are then solved one after the other and there is no second level-1 search),
    warming up from now on, while level 1 runs; with `warmed`, returned only once every
    process has (the bench starts its clock then). End it with `end_pool`."""
    if processes <= 1:
        return None
    # The service's solve processes are daemons (they must not outlive it), and daemons
    # may not have children unless they say otherwise: end_pool ends this pool, and its
    # processes end themselves should this one die first (pool_process_init).
    multiprocessing.current_process().daemon = False
    pool = ProcessPoolExecutor(processes, mp_context=multiprocessing.get_context("spawn"),
                               initializer=pool_process_init, initargs=(os.getpid(),))
    warming = [pool.submit(warm_up) for _ in range(processes)]
    if warmed:
        wait(warming)
    return pool


def end_pool(pool: ProcessPoolExecutor | None) -> None:
    """Stop the pool now: a sub-domain or second search still running must not hold up
    the layout (ProcessPoolExecutor has no public way to end busy workers before Python
    3.14's terminate_workers)."""
    if pool is None:
        return
    processes = list(getattr(pool, "_processes", {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.kill()
    # The pool's manager thread reaps the killed workers too. Had we reaped one first,
    # its own wait would fail and leave the Process alive in appearance until the
    # manager sets its exit code, so let the manager finish before looking.
    if manager is not None:
        manager.join(timeout=END_POOL_SECONDS)
    for process in processes:
        process.join(timeout=END_POOL_SECONDS)


def pool_process_init(parent: int) -> None:
    """Pool initializer. Ctrl-C is for the solve that owns the pool to act on (it ends
    the pool), not for each of its processes; and this process ends once `parent`,
    the process that started the pool, is gone: a parent killed outright (the
    service's hard time limit, a second Ctrl-C) cannot end its pool, and idle workers
    would wait on its queue forever."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL)
        os._exit(1)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def warm_up() -> None:
    """Submitted once per pool process, so that it imports the sub-domain solver (and SCIP,
    shapely) while level 1 runs, not when the first sub-domain waits; and the solve
    module, which a second level-1 search runs from."""
    import floorplan.solver.pipeline.second_search
    import floorplan.solver.pipeline.subdomains  # noqa: F401
