"""A service batch's layout moved apart from the batch's finished plans (issue 23): the
store gives the runner the batch's layouts, the solve's process moves a repeated plan's
walls (service.batch.apart_from_held, solver/pipeline/spread.py)."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import pytest
from sqlalchemy import update

from floorplan.models import Layout, Problem
from floorplan.models.jobs import JobStatus
from floorplan.service.batch import MOVED_APART, LayoutTask, apart_from_held, job_problem
from floorplan.service.jobs.processes import Runner
from floorplan.service.settings import Settings
from floorplan.service.store import JobStore
from floorplan.service.tables import jobs
from floorplan.solver import solve
from floorplan.solver.distinct import DistinctPlans

APARTMENT = json.loads(Path("examples/apartment-5.json").read_text())


def _store(tmp_path: Path) -> JobStore:
    return JobStore(f"sqlite:///{tmp_path / 'jobs.db'}")


def test_the_store_gives_a_batch_s_finished_layouts_newest_first(tmp_path: Path) -> None:
    store = _store(tmp_path)
    _, made = store.create_batch(owner="o", name="b", seed=0, vary_program=False,
                                 brief=json.dumps(APARTMENT), count=4, time_limit=1.0,
                                 time_ceiling=600, job_time_limit=1.0)
    store.finish(made[0].id, JobStatus.SUCCEEDED, termination="optimal", result='"first"')
    store.finish(made[1].id, JobStatus.FAILED, error={"code": "x", "message": "y"})
    store.finish(made[2].id, JobStatus.SUCCEEDED, termination="optimal", result='"third"')
    running = store.get(made[3].id, owner="o")
    assert running is not None and running.batch_id == made[0].batch_id is not None
    assert store.batch_plans(running.batch_id, limit=5) == ['"third"', '"first"']
    assert store.batch_plans(running.batch_id, limit=1) == ['"third"']
    lone, _ = store.create(problem="{}", time_limit=1, owner="o")
    assert lone.batch_id is None


@pytest.mark.slow
def test_the_runner_moves_a_batch_layout_that_repeats_a_finished_one(tmp_path: Path) -> None:
    # The same seed twice in one batch: the second solve finds the first one's plan,
    # asks the runner for the batch's layouts and moves its walls apart from it.
    settings = Settings(data_dir=tmp_path, workers=1, subdomain_processes=1)
    store = JobStore(settings.store_url)
    problem = job_problem(LayoutTask(APARTMENT, 4, 20.0, good_enough=math.inf))
    _, made = store.create_batch(owner="", name="twice", seed=4, vary_program=False,
                                 brief=json.dumps(APARTMENT), count=2, time_limit=20.0,
                                 time_ceiling=600, job_time_limit=10.0)
    # Both layouts given the first one's problem, as a batch made before the brief was
    # stored once holds them in its jobs (the store derives a job's problem only when
    # it holds none).
    with store.engine.begin() as conn:
        conn.execute(update(jobs).where(jobs.c.batch_id == made[0].batch_id).values(
            problem=problem.model_dump_json(), time_limit=10.0))
    runner = Runner(store, settings)
    runner.start()
    try:
        deadline = time.monotonic() + 60
        while store.count(JobStatus.SUCCEEDED) < 2:
            assert time.monotonic() < deadline, "the batch did not finish"
            time.sleep(0.2)
    finally:
        runner.stop()
    # The jobs were made together: either may have run first.
    first, second = sorted((store.get(job.id) for job in made),
                           key=lambda job: job.finished_at if job else 0)
    assert first is not None and second is not None
    assert first.result is not None and second.result is not None
    plans = DistinctPlans()
    plans.add(Layout.model_validate_json(first.result))
    moved = Layout.model_validate_json(second.result)
    assert moved.report.valid and plans.is_new(moved)
    details = [json.loads(e.data).get("detail") for e in store.events_after(second.id, 0)
               if e.kind == "progress"]
    # Moved apart: the runner answered its ask for the batch's plans (unanswered, the
    # layout would stay as solved).
    assert MOVED_APART in details


def test_a_repeated_plan_is_moved_apart_and_a_new_one_left_as_solved() -> None:
    # 20 s, far above what the layout needs (it ends at its first good one): at 4 s a
    # busy machine once ended it on a layout whose walls could not be moved.
    problem = Problem.model_validate(APARTMENT).with_options(
        seed=4, time_limit=20, diverse=True, stop_when_good=True)
    layout = solve(problem)
    assert layout.report.valid and layout.report.coverage >= 0.99
    assert apart_from_held(problem, layout, []) == (layout, None)
    moved, done = apart_from_held(problem, layout, [layout.model_dump_json()])
    assert done == MOVED_APART
    assert moved.report.valid and moved.report.coverage >= layout.report.coverage - 1e-9
    plans = DistinctPlans()
    plans.add(layout)
    assert plans.is_new(moved)


def test_a_layout_that_is_not_good_is_left_as_it_is() -> None:
    problem = Problem.model_validate(APARTMENT)
    bare = Layout.model_validate(
        {"rooms": [], "report": {"coverage": 0.0, "uncovered_area": 84.0, "valid": False}})
    assert apart_from_held(problem, bare, [bare.model_dump_json()]) == (bare, None)


def test_a_plan_that_cannot_be_moved_is_laid_out_again_and_kept_when_no_better() -> None:
    # One room filling its floor: no wall to move, and another draw gives the same plan.
    studio = Problem.model_validate({
        "boundary": [[0, 0], [4, 0], [4, 3], [0, 3]],
        "rooms": [{"id": "studio", "min_size": [4, 3], "max_size": [4, 3],
                   "target_size": [4, 3]}],
    }).with_options(seed=1, time_limit=2, diverse=True, stop_when_good=True)
    layout = solve(studio)
    seeds: list[int] = []

    def again(redrawn: Problem) -> Layout:
        seeds.append(redrawn.options.seed)
        return solve(redrawn)

    assert apart_from_held(studio, layout, [layout.model_dump_json()], again=again) == (
        layout, None)
    assert seeds == [1 + 7_000_003]
