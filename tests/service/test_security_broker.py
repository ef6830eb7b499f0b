"""The security review (docs/security.md), sub-domain tasks through Redis: what a
writer to Redis sends is data, never code; each finding replayed against real
workers and the machine's Redis."""

from __future__ import annotations

import base64
import json
import math
import pickle
import re
import time
from concurrent.futures import Executor, Future
from dataclasses import replace
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest

from floorplan.service.jobs.broker.codec import (
    CodecError,
    decode_outcome,
    decode_task,
    encode_outcome,
    encode_task,
)
from floorplan.solver.geometry import Box, Edge, Notch
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec, Refine
from floorplan.solver.pipeline.subdomains import SubdomainExecutor, SubdomainOutcome, SubdomainTask
from tests.servers import Cluster
from tests.service.test_service import wait

KEY = {"Authorization": "Bearer alpha"}
#: One solve at a time and no sub-domain pool: these tests solve little.
QUIET = {"WORKERS": "1", "FLOORPLAN_SUBDOMAIN_PROCESSES": "1"}



# Sub-domain tasks through Redis: data, never code.


def full_task() -> SubdomainTask:
    """A task with every field of every dataclass away from its default."""
    b = Box(0.0, 0.5, 4.0, 3.25)
    edge = Edge(index=2, start=(0.0, 0.0), end=(4.0, 0.0), facing="south")
    rect = RectSpec(
        name="r0", room="living", min_size=(2.0, 2.5), max_size=(math.inf, 5.0),
        target=(3.5, 4.0), aspect_ratio=(0.5, 2.0), positions=((1.0, 1.0), (2.0, 2.5)),
        edges=(edge,), refine=Refine(parent=b, direction="horizontal", child=-1, delta=0.3),
        fixed=Box(1, 1, 2, 2), soft=frozenset({"min_size", "positions"}), floor=(1.5, 1.5),
        may_wrap=False,
    )
    spec = LevelSpec(
        name="level 2 / rooms a, b", region=b, blocked=(Box(3, 0, 4, 1),), free_area=12.5,
        rects=(rect, RectSpec(name="r1", room="bed")),
        contacts=(ContactSpec(name="adj", a=("r0",), partners=(("r1",), ("r0", "r1")),
                              min_contact=1.0, soft=True),),
        envelopes=(EnvelopeSpec(room="living", rects=("r0", "r1"), previous=None,
                                max_size=(6.0, math.inf), aspect_ratio=(0.25, 4.0),
                                soft=frozenset({"max_size"}), min_size=(2.0, 2.0),
                                positions=((1.0, 2.0),)),
                   EnvelopeSpec(room="bed", rects=("r1",), previous=Box(0, 0, 1, 1),
                                max_size=(3.0, 3.0), aspect_ratio=None)),
        cover_weight=2.0, size_weight=0.5, growth_weight=0.1, violation_weight=100.0,
        notches=(Notch(obstacle=Box(3, 0, 4, 1), hull=Box(2.8, 0, 4, 1.2)),),
    )
    return SubdomainTask(spec=spec, start={"r0": Box(0, 0.5, 2, 2), "r1": b}, budget=1.5,
                         deadline=1.8e9, seed=7)


def test_a_sub_domain_task_and_its_outcome_round_trip_through_json() -> None:
    task = full_task()
    text = encode_task(task)
    assert decode_task(text) == task
    json.loads(text)  # plain JSON (Infinity aside, which Python's reader takes)
    for outcome in (SubdomainOutcome("optimal", {"r0": Box(0, 0, 1.25, 2)}, -3.5, 0.25),
                    SubdomainOutcome("start not feasible: infeasible", None, None, 0.0)):
        assert decode_outcome(encode_outcome(outcome)) == outcome


@pytest.mark.slow
def test_real_sub_domains_round_trip_and_solve_through_the_codec() -> None:
    from floorplan.models import Problem
    from floorplan.solver import solve
    from tests.solver.pipeline.test_parallel import TWO_WINGS

    sent: list[SubdomainTask] = []

    class ThroughJson(Executor):
        """Runs each task here, after a trip through the codec both ways."""

        def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
            future: Future[Any] = Future()
            (task,) = args
            if not isinstance(task, SubdomainTask):  # a second level-1 search: refused
                future.set_exception(ValueError("sub-domains only"))
                return future
            copy = decode_task(encode_task(task))
            assert copy == task
            sent.append(copy)
            future.set_result(decode_outcome(encode_outcome(fn(copy))))
            return future

    layout = solve(Problem.model_validate(TWO_WINGS),
                   subdomains=SubdomainExecutor(ThroughJson(), 2))
    assert sent, "the solve sent no sub-domain"
    assert layout.report.valid and {r.id for r in layout.rooms} == {"a", "b", "c", "d"}


class Plant:
    """A pickle that, once loaded, creates the file `path`: what an attacker with
    write access to Redis would send."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self) -> tuple[Any, ...]:
        return (open, (str(self.path), "w"))


@pytest.mark.parametrize("payload", [
    "not json", "[]", '{"v": 2, "task": {}}', '{"v": 1, "task": {"spec": 1}}',
    json.dumps({"v": 1, "task": {**json.loads(encode_task(full_task()))["task"],
                                 "seed": True}}),
    json.dumps({"v": 1, "task": {**json.loads(encode_task(full_task()))["task"],
                                 "extra": 1}}),
])
def test_anything_but_an_encoded_task_fails_to_decode(payload: str) -> None:
    with pytest.raises(CodecError):
        decode_task(payload)


def test_a_pickled_payload_fails_to_decode_and_runs_nothing(tmp_path: Path) -> None:
    marker = tmp_path / "planted"
    payload = base64.b64encode(pickle.dumps(Plant(marker))).decode()
    with pytest.raises(CodecError):
        decode_task(payload)
    assert not marker.exists()


@pytest.mark.slow
def test_a_sub_domain_worker_refuses_a_pickle_and_runs_no_code(tmp_path: Path) -> None:
    from celery import Celery

    from floorplan.service.jobs.broker.config import SUBDOMAIN_TASK, Keys, make_celery
    from floorplan.service.settings import Settings
    from tests.solver.pipeline.test_parallel import TWO_WINGS

    cluster = Cluster(tmp_path / "cluster", workers=1, WORKERS="1",
                      FLOORPLAN_SUBDOMAINS="celery").start()
    celery: Celery | None = None
    try:
        cluster.add_subdomain_worker()
        settings = Settings(redis_url=cluster.redis_url, namespace=cluster.name)
        keys = Keys(cluster.name)
        celery = make_celery(settings)

        # The old attack: a JSON message whose argument is a pickle (the worker used to
        # unpickle it). It now fails to decode, and the file is never made.
        marker = tmp_path / "planted-by-argument"
        payload = base64.b64encode(pickle.dumps(Plant(marker))).decode()
        result = celery.send_task(SUBDOMAIN_TASK, args=[payload], queue=keys.subdomains)
        with pytest.raises(Exception, match=r"CodecError|JSON|task"):
            result.get(timeout=60)
        assert result.state == "FAILURE" and not marker.exists()

        # A message pickled whole: the worker accepts JSON only and drops it unread.
        whole = tmp_path / "planted-by-message"
        celery.send_task(SUBDOMAIN_TASK, args=[Plant(whole)], queue=keys.subdomains,
                         serializer="pickle")
        # It is refused before anything runs; a valid task sent after it still is.
        # (A deadline within FLOORPLAN_MAX_TIME_LIMIT of now: the worker refuses later ones.)
        after = celery.send_task(SUBDOMAIN_TASK, args=[encode_task(
            replace(full_task(), budget=0.0, deadline=time.time() + 30))],
            queue=keys.subdomains, serializer="json")
        outcome = decode_outcome(after.get(timeout=60))
        assert outcome.status.startswith("not started")
        time.sleep(1)
        assert not marker.exists() and not whole.exists()
        log = (tmp_path / "cluster" / "sub.log").read_text()
        assert "CodecError" in log
        assert re.search(r"untrusted content|refusing|ContentDisallowed", log, re.I), log[-3000:]

        # And a real solve still sends its sub-domains there, as JSON, and gets them back.
        with httpx.Client(base_url=cluster.url, timeout=30) as http:
            answer = http.post("/v1/layouts", json=TWO_WINGS)
            assert answer.status_code == 202
            done = wait(http, answer.json()["id"])
            assert done["status"] == "succeeded", done
            layout = http.get(f"/v1/layouts/{done['id']}/result").json()
            assert layout["report"]["valid"] and len(layout["rooms"]) == 4
        log = (tmp_path / "cluster" / "sub.log").read_text()
        solved = re.findall(r"Task floorplan\.subdomain\[[^]]+\] succeeded", log)
        assert len(solved) >= 3, log[-2000:]  # the valid one above, and the solve's
    finally:
        if celery is not None:
            celery.close()
        cluster.stop()
