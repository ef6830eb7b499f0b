"""The sub-domains of one refinement level solved at the same time (subdomains.py, pool.py):
in a local process pool from `solve`, and in the service, whose solve processes start
such a pool when FLOORPLAN_SUBDOMAIN_PROCESSES asks for one."""

from __future__ import annotations

import json
import multiprocessing
import os
import subprocess
import threading
import time
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from floorplan.models import Problem
from floorplan.service.jobs.child import run_job, standby
from floorplan.service.jobs.processes import SolveProcesses
from floorplan.solver import solve
from floorplan.solver.events import Phase, SolveEvent
from floorplan.solver.geometry import Box, make_domain
from floorplan.solver.openings import connection_demands
from floorplan.solver.pipeline.hierarchy import SubDomain, room_boxes
from floorplan.solver.pipeline.pool import PARENT_POLL, subdomain_pool
from floorplan.solver.pipeline.refine import _disjoint_batches
from floorplan.solver.pipeline.run import Run
from floorplan.solver.pipeline.second_search import awaited, better_start, level_one_alone
from floorplan.solver.pipeline.subdomains import (
    LevelOneOutcome,
    LevelOneTask,
    SubdomainExecutor,
    overlaps_others,
)
from floorplan.solver.verify.checker import check_layout
from tests.servers import Server
from tests.service.test_service import submit, wait

#: Two wings behind a wall, two rooms each, too small to fill their wing: every
#: refinement level has two sub-domains with no room in common.
TWO_WINGS: dict[str, Any] = {
    "name": "two-wings",
    "boundary": [[0, 0], [17, 0], [17, 4], [0, 4]],
    "obstacles": [{"x": 8, "y": 0, "width": 1, "depth": 4, "label": "wall"}],
    "rooms": [{"id": rid, "min_size": [2.5, 3], "max_size": [3.6, 4], "target_size": [3.6, 4],
               "positions": [[x, 2]]} for rid, x in (("a", 1), ("b", 7), ("c", 10), ("d", 16))],
    # Far above the need (the stall rule ends the solve): level 1 ends with time left for
    # the sub-domains on a busy machine too; 5 s once left none under load.
    "options": {"time_limit": 30, "seed": 1},
}


@pytest.fixture(scope="module")
def pool() -> Iterator[ProcessPoolExecutor]:
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as executor:
        yield executor


def test_sub_domains_sharing_rooms_go_to_separate_batches() -> None:
    subs = [SubDomain(frozenset(r)) for r in ({"a", "b"}, {"c"}, {"b", "d"}, {"e"})]
    batches = _disjoint_batches(subs)
    assert [[i for i, _ in batch] for batch in batches] == [[0, 1], [2, 3]]


def test_overlaps_count_other_rooms_only_and_not_touching_walls() -> None:
    rooms = {"a": [Box(0, 0, 2, 2)], "b": [Box(2, 0, 4, 2)]}
    assert not overlaps_others(rooms, {"a"}, [Box(0, 0, 2, 2)])   # its own old box
    assert not overlaps_others(rooms, {"a"}, [Box(0, 0, 2, 3)])   # touches b
    assert overlaps_others(rooms, {"a"}, [Box(0, 0, 2.5, 2)])     # into b


@pytest.mark.slow
def test_a_level_s_sub_domains_are_solved_at_once_in_a_process_pool(
    pool: ProcessPoolExecutor,
) -> None:
    events: list[SolveEvent] = []
    layout = solve(Problem.model_validate(TWO_WINGS), on_event=events.append,
                   subdomains=SubdomainExecutor(pool, 2))
    assert layout.report.valid and {r.id for r in layout.rooms} == {"a", "b", "c", "d"}
    solved = [e for e in events if e.phase is Phase.SUBDOMAIN]
    assert solved and all(" in " in e.detail for e in solved)  # through the pool
    levels = {e.level for e in solved}
    for level in levels:  # both sub-domains of every level, one in each wing
        details = sorted(e.detail.split(":")[0] for e in solved if e.level == level)
        assert details == ["rooms a, b", "rooms c, d"]
    sequential = solve(Problem.model_validate(TWO_WINGS))
    assert sequential.report.valid
    assert layout.report.coverage >= sequential.report.coverage - 1e-6


def test_a_second_level_one_search_runs_in_the_pool_and_the_better_start_wins(
    pool: ProcessPoolExecutor,
) -> None:
    problem = connection_demands(Problem.model_validate(TWO_WINGS))
    domain = make_domain(problem)
    # Level 1 ends at its first layout (half a second); the deadline, counted from the
    # submission, leaves a busy machine time to start the pool's process too.
    outcome = pool.submit(level_one_alone, LevelOneTask(
        problem, deadline=time.time() + 60)).result(timeout=120)
    assert outcome.pieces is not None and not outcome.soft
    rooms = room_boxes(outcome.pieces)
    assert set(rooms) == {"a", "b", "c", "d"}
    assert check_layout(problem, rooms).valid

    def finished(**changes: Any) -> Future[LevelOneOutcome]:
        done: Future[LevelOneOutcome] = Future()
        done.set_result(replace(outcome, **changes))
        return done

    events: list[SolveEvent] = []
    run = Run(problem, time.monotonic() + 5, time.monotonic(), events.append, None)
    # A tie keeps this search's layout, and says nothing.
    kept = better_start(run, domain, outcome.pieces, awaited(finished(), run, time.monotonic()))
    assert kept is outcome.pieces and not events
    # No layout here: the second search's is taken, and said so.
    other = better_start(run, domain, None, awaited(finished(), run, time.monotonic()))
    assert other is outcome.pieces
    assert any("second search" in e.detail for e in events)
    # A second search that is still running when level 1 ends is not waited for.
    running: Future[LevelOneOutcome] = Future()
    assert awaited(running, run, time.monotonic() - 1) is None
    assert better_start(run, domain, None, None) is None


@pytest.mark.slow
def test_a_solve_process_runs_its_sub_domains_in_a_pool_and_ends_it() -> None:
    messages: multiprocessing.Queue[tuple[str, Any]] = multiprocessing.Queue()
    before = set(multiprocessing.active_children())
    run_job(json.dumps(TWO_WINGS), messages, multiprocessing.Event(), os.getppid(),
            subdomain_processes=2)
    received = []
    while (message := messages.get(timeout=60))[0] not in ("done", "error"):
        received.append(message)
    assert message[0] == "done", message
    details = [m[1]["detail"] for m in received if m[0] == "progress"
               and m[1]["phase"] == "subdomain"]
    assert details and all(" in " in d for d in details)  # solved by the pool
    assert json.loads(message[1])["report"]["valid"]
    assert set(multiprocessing.active_children()) <= before  # its pool is gone with it


@pytest.mark.slow
def test_a_standby_solve_process_starts_its_pool_before_the_job_comes() -> None:
    jobs, send = multiprocessing.Pipe(duplex=False)
    messages: multiprocessing.Queue[tuple[str, Any]] = multiprocessing.Queue()
    before = set(multiprocessing.active_children())
    waiting = threading.Thread(target=standby, args=(jobs, messages, multiprocessing.Event(),
                                                     os.getppid(), 2))
    waiting.start()
    give_up = time.monotonic() + 30
    while len(set(multiprocessing.active_children()) - before) < 2 and (
            time.monotonic() < give_up):
        time.sleep(0.05)
    assert len(set(multiprocessing.active_children()) - before) == 2  # no job yet
    send.send(json.dumps(TWO_WINGS))
    waiting.join(timeout=60)
    received = []
    while (message := messages.get(timeout=60))[0] not in ("done", "error"):
        received.append(message)
    assert message[0] == "done", message
    assert any(m[0] == "progress" and m[1]["phase"] == "subdomain"
               and " in " in m[1]["detail"] for m in received)  # solved by that pool
    assert set(multiprocessing.active_children()) <= before


def test_waiting_solve_processes_end_their_pools_and_exit_when_the_service_closes() -> None:
    processes = SolveProcesses(subdomain_processes=2)
    processes.refill(1)
    waiting = processes._ready[0].process
    give_up = time.monotonic() + 60
    while len(_children(waiting.pid)) < 2:  # its imports done and its pool started
        assert time.monotonic() < give_up, "the waiting process started no pool"
        time.sleep(0.05)
    processes.close()
    assert waiting.exitcode == 0  # it ended by itself, not killed


def _children(pid: int) -> list[int]:
    """The spawned children of `pid` (their command line runs spawn_main)."""
    out = subprocess.run(["ps", "-ww", "-o", "pid=,args=", "--ppid", str(pid)],
                         capture_output=True, text=True).stdout
    return [int(line.split()[0]) for line in out.splitlines() if "spawn_main" in line]


def _pool_pid(seconds: float) -> int:
    time.sleep(seconds)  # both workers get one: neither is idle when the other is asked
    return os.getpid()


def _start_a_pool_and_die(pids: multiprocessing.Queue[list[int]]) -> None:
    pool = subdomain_pool(2)
    assert pool is not None
    pids.put([f.result(timeout=60) for f in [pool.submit(_pool_pid, 1.0) for _ in range(2)]])
    pids.close()
    pids.join_thread()  # os._exit would not wait for the queue's feeder thread
    os._exit(0)  # as a hard kill or a second Ctrl-C would: end_pool never runs


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"  # a zombie is gone
    except FileNotFoundError:
        return False


@pytest.mark.slow
@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="reads /proc")
def test_a_pool_whose_parent_dies_ends_itself() -> None:
    pids: multiprocessing.Queue[list[int]] = multiprocessing.get_context("spawn").Queue()
    parent = multiprocessing.get_context("spawn").Process(target=_start_a_pool_and_die,
                                                          args=(pids,))
    parent.start()
    workers = pids.get(timeout=90)
    parent.join(timeout=60)
    assert len(set(workers)) == 2 and parent.exitcode == 0
    give_up = time.monotonic() + 120 * PARENT_POLL  # a minute: a busy machine polls late
    while any(_alive(pid) for pid in workers) and time.monotonic() < give_up:
        time.sleep(0.1)
    assert not any(_alive(pid) for pid in workers)


@pytest.mark.slow
def test_the_service_with_a_sub_domain_pool_per_solve(tmp_path: Path) -> None:
    # The real chain: a spawned (daemonic) solve process starting its own pool.
    s = Server(tmp_path, FLOORPLAN_SUBDOMAIN_PROCESSES="2", WORKERS="1").start()
    try:
        with httpx.Client(base_url=s.url, timeout=30) as client:
            job = submit(client, TWO_WINGS)
            done = wait(client, job["id"])
            assert done["status"] == "succeeded", done
            result = client.get(f"/v1/layouts/{job['id']}/result").json()
            assert result["report"]["valid"] and len(result["rooms"]) == 4
    finally:
        s.stop()


@pytest.mark.slow
def test_the_benchmark_runs_ours_with_a_sub_domain_pool() -> None:
    from bench.solvers import run_ours

    trace = run_ours(Problem.model_validate(TWO_WINGS), seed=1, subdomain_processes=2)
    assert trace.solver == "ours-parallel" and trace.final is not None
    assert trace.extra["subdomains_solved"] >= 2 and trace.extra["refine_seconds"] > 0
