"""The security review (docs/security.md), each finding replayed against a real server
process on loopback (tests/servers.py), the machine's PostgreSQL or Redis: what an
attacker did must now fail."""

from __future__ import annotations

import base64
import itertools
import json
import math
import pickle
import re
import threading
import time
import uuid
from collections.abc import Iterator
from concurrent.futures import Executor, Future
from dataclasses import replace
from pathlib import Path
from typing import Any

import httpx2 as httpx
import pytest
import redis
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from floorplan.models.jobs import JobStatus
from floorplan.service.jobs.broker.codec import (
    CodecError,
    decode_outcome,
    decode_task,
    encode_outcome,
    encode_task,
)
from floorplan.service.store import JobStore
from floorplan.service.tables import metadata
from floorplan.solver.geometry import Box, Edge, Notch
from floorplan.solver.miqp.spec import ContactSpec, EnvelopeSpec, LevelSpec, RectSpec, Refine
from floorplan.solver.pipeline.subdomains import SubdomainExecutor, SubdomainOutcome, SubdomainTask
from tests.servers import Cluster, Server, schema_url
from tests.service.test_service import SMALL, wait

KEY = {"Authorization": "Bearer alpha"}
#: One solve at a time and no sub-domain pool: these tests solve little.
QUIET = {"WORKERS": "1", "FLOORPLAN_SUBDOMAIN_PROCESSES": "1"}


@pytest.fixture(scope="module")
def keyed(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    server = Server(tmp_path_factory.mktemp("keyed"), FLOORPLAN_API_KEYS="alpha",
                    **QUIET).start()
    yield server
    server.stop()


@pytest.mark.slow
def test_validate_needs_the_api_key_explain_included(keyed: Server) -> None:
    with httpx.Client(base_url=keyed.url, timeout=30) as client:
        for params in ({}, {"explain": "true", "time_limit": "30"}):
            refused = client.post("/v1/validate", json=SMALL, params=params)
            assert refused.status_code == 401, refused.text
            assert refused.headers["content-type"] == "application/problem+json"
            assert refused.json()["status"] == 401
            assert refused.headers["www-authenticate"] == "Bearer"
            wrong = client.post("/v1/validate", json=SMALL, params=params,
                                headers={"X-API-Key": "gamma"})
            assert wrong.status_code == 401
        allowed = client.post("/v1/validate", json=SMALL, headers=KEY)
        assert allowed.status_code == 200 and allowed.json()["valid"]
        explained = client.post("/v1/validate", json=SMALL, headers={"X-API-Key": "alpha"},
                                params={"explain": "true", "time_limit": "2"})
        assert explained.status_code == 200 and explained.json()["feasible"] is True


@pytest.mark.slow
def test_readyz_stays_public_but_shows_its_figures_only_with_a_key(keyed: Server) -> None:
    with httpx.Client(base_url=keyed.url, timeout=30) as client:
        anyone = client.get("/readyz")
        assert anyone.status_code == 200
        assert anyone.json() == {"status": "ready"}
        wrong = client.get("/readyz", headers={"Authorization": "Bearer gamma"})
        assert wrong.status_code == 200 and "queued" not in wrong.json()
        trusted = client.get("/readyz", headers=KEY).json()
        assert trusted["status"] == "ready"
        assert trusted["running"] == 0 and trusted["queued"] == 0


@pytest.mark.slow
def test_a_keyed_cluster_shows_its_workers_only_with_a_key(tmp_path: Path) -> None:
    # The distributed mode's /readyz adds the broker and the live workers; the start
    # (tests/servers.py, as scripts/run-distributed.sh) waits for them with the key.
    cluster = Cluster(tmp_path, workers=1, WORKERS="1", FLOORPLAN_API_KEYS="alpha").start()
    try:
        with httpx.Client(base_url=cluster.url, timeout=30) as client:
            anyone = client.get("/readyz")
            assert anyone.status_code == 200
            assert anyone.json() == {"status": "ready", "backend": "celery", "broker": "ok"}
            trusted = client.get("/readyz", headers=KEY).json()
            assert trusted["workers"] == 1 and trusted["queued"] == 0
            assert client.post("/v1/validate", json=SMALL).status_code == 401
    finally:
        cluster.stop()


@pytest.mark.slow
def test_without_keys_readyz_and_validate_are_open_as_before(tmp_path: Path) -> None:
    server = Server(tmp_path, **QUIET).start()
    try:
        with httpx.Client(base_url=server.url, timeout=30) as client:
            ready = client.get("/readyz").json()
            assert ready["status"] == "ready" and ready["queued"] == 0
            assert client.post("/v1/validate", json=SMALL).json()["valid"]
    finally:
        server.stop()


def building(floors: int, time_limit: float | None = None) -> dict[str, Any]:
    """`floors` storeys of four 2 x 2 m rooms each on an 8 x 8 m footprint."""
    return {
        "name": f"tower-{floors}",
        "boundary": [[0, 0], [8, 0], [8, 8], [0, 8]],
        "floors": [{"id": f"f{k}", "rooms": [
            {"id": f"r{j}", "type": "office", "min_size": [2, 2], "max_size": [6, 6]}
            for j in range(4)]} for k in range(floors)],
        "options": {} if time_limit is None else {"time_limit": time_limit},
    }


@pytest.mark.slow
def test_the_time_limit_ceiling_holds_for_a_whole_building(tmp_path: Path) -> None:
    # 100 floors of 4 rooms: each floor's default is 5 s, 500 s summed, past a 30 s
    # ceiling. The job runs under the ceiling instead, and says so in its time_limit.
    server = Server(tmp_path, FLOORPLAN_MAX_TIME_LIMIT="30", **QUIET).start()
    try:
        with httpx.Client(base_url=server.url, timeout=60) as client:
            answer = client.post("/v1/layouts", json=building(100))
            assert answer.status_code == 202, answer.text
            job = answer.json()
            assert job["time_limit"] == 30
            client.post(f"/v1/layouts/{job['id']}/cancel")
            assert client.get(f"/v1/layouts/{job['id']}").json()["time_limit"] == 30
            wait(client, job["id"])
            # The cancel, sent while the job was being claimed, stopped it: it did not
            # solve its 100 floors to the end (it did, in 25 s, before the fix).
            ended = client.get(f"/v1/layouts/{job['id']}").json()
            assert (ended["status"], ended["termination"]) == ("canceled", "interrupted")
            # A limit the user states above the ceiling is still refused, by name.
            refused = client.post("/v1/layouts", json=building(100, time_limit=31))
            assert refused.status_code == 422
            assert refused.headers["content-type"] == "application/problem+json"
            assert [e["field"] for e in refused.json()["errors"]] == ["options.time_limit"]
            # Within the ceiling, the default stands (two floors: 10 s).
            small = client.post("/v1/layouts", json=building(2))
            assert small.status_code == 202 and small.json()["time_limit"] == 10
            client.post(f"/v1/layouts/{small.json()['id']}/cancel")
            wait(client, small.json()["id"])
    finally:
        server.stop()


# Idempotency-Key under concurrency, on the machine's PostgreSQL.

PARALLEL = 16


def at_once(count: int, call: Any) -> list[Any]:
    """`call(k)` for k < count in as many threads, released together; their answers."""
    start = threading.Barrier(count)
    answers: list[Any] = [None] * count

    def run(k: int) -> None:
        start.wait()
        answers[k] = call(k)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(count)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return answers


def test_one_idempotency_key_makes_one_job_in_the_store_under_a_race() -> None:
    store = JobStore(schema_url(f"fptest_{uuid.uuid4().hex[:12]}"))
    made = at_once(PARALLEL, lambda _k: store.create(
        problem="{}", time_limit=1, owner="o", idempotency_key="order-1", body_hash="h"))
    assert len({job.id for job, _new in made}) == 1
    assert sum(new for _job, new in made) == 1
    assert len(store.list(owner="o", status=None, limit=100, after=None)) == 1


@pytest.mark.slow
def test_sixteen_parallel_posts_with_one_key_make_one_job(tmp_path: Path) -> None:
    url = schema_url(f"fptest_{uuid.uuid4().hex[:12]}")
    server = Server(tmp_path, FLOORPLAN_DATABASE_URL=url, **QUIET).start()
    try:
        def post(_k: int) -> httpx.Response:
            with httpx.Client(base_url=server.url, timeout=60) as own:
                return own.post("/v1/layouts", json=SMALL,
                                headers={"Idempotency-Key": "order-16"})

        answers = at_once(PARALLEL, post)
        assert [a.status_code for a in answers] == [202] * PARALLEL, \
            [a.text for a in answers if a.status_code != 202]
        ids = {a.json()["id"] for a in answers}
        assert len(ids) == 1
        assert {a.headers["location"] for a in answers} == {f"/v1/layouts/{ids.pop()}"}
        with httpx.Client(base_url=server.url, timeout=60) as client:
            jobs = client.get("/v1/layouts").json()["data"]
            assert len(jobs) == 1
            wait(client, jobs[0]["id"])
    finally:
        server.stop()


@pytest.mark.parametrize("database", ["sqlite", "postgresql"])
def test_the_migration_keeps_a_duplicated_key_on_the_oldest_job_only(
    database: str, tmp_path: Path,
) -> None:
    from alembic import command
    from sqlalchemy import create_engine, text

    from floorplan.service.migrations import alembic_config

    url = (f"sqlite:///{tmp_path / 'jobs.sqlite3'}" if database == "sqlite"
           else schema_url(f"fptest_{uuid.uuid4().hex[:12]}"))
    engine = create_engine(url)
    config = alembic_config()
    with engine.begin() as conn:  # the schema before the unique index, raced twice
        config.attributes["connection"] = conn
        command.upgrade(config, "0002")
        for job_id, created in (("b", 2.0), ("a", 1.0), ("c", 2.0)):
            conn.execute(text(
                "INSERT INTO jobs (id, owner, status, problem, time_limit, idempotency_key,"
                " body_hash, attempts, cancel_requested, created_at, updated_at) VALUES"
                " (:id, 'o', 'queued', '{}', 1, 'k', 'h', 0, false, :at, :at)"),
                {"id": job_id, "at": created})
    engine.dispose()
    store = JobStore(url)  # migrates to the newest revision
    kept = {job_id: job.idempotency_key for job_id in "abc"
            if (job := store.get(job_id)) is not None}
    assert kept == {"a": "k", "b": None, "c": None}
    again, new = store.create(problem="{}", time_limit=1, owner="o", idempotency_key="k",
                              body_hash="h")
    assert again.id == "a" and not new
    with store.engine.connect() as conn:  # the schema the store's tables describe
        assert compare_metadata(MigrationContext.configure(conn), metadata) == []


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
        cluster.add_worker("sub", "--subdomains", log_level="info")
        settings = Settings(redis_url=cluster.redis_url, namespace=cluster.name)
        keys = Keys(cluster.name)
        client = redis.Redis.from_url(cluster.redis_url)
        deadline = time.monotonic() + 60
        while not list(client.scan_iter(f"{keys.subdomain_workers}*")):
            assert time.monotonic() < deadline, "the sub-domain worker did not start"
            time.sleep(0.2)
        client.close()
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


def test_a_page_of_jobs_leaves_the_stored_layouts_in_the_database(tmp_path: Path) -> None:
    # Listing 200 jobs once loaded every result column (0.37 -> 1.46 GB).
    store = JobStore(f"sqlite:///{tmp_path / 'jobs.db'}")
    job, _ = store.create(problem='{"rooms": []}', time_limit=1, owner="o")
    store.finish(job.id, JobStatus.SUCCEEDED, termination="optimal", result="x" * 1_000_000)
    [listed] = store.list(owner="o", status=None, limit=200, after=None)
    assert listed.id == job.id and listed.status is JobStatus.SUCCEEDED
    assert listed.result is None and listed.problem == "" and listed.incumbent is None
    full = store.get(job.id, owner="o")
    assert full is not None and full.result is not None and len(full.result) == 1_000_000


# Cross-site requests and DNS rebinding onto a service on loopback.


@pytest.fixture(scope="module")
def open_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    """No keys (the default), on loopback with the default allowed hosts."""
    server = Server(tmp_path_factory.mktemp("open"), **QUIET).start()
    yield server
    server.stop()


@pytest.mark.slow
@pytest.mark.parametrize("path", ["/v1/layouts", "/v1/validate"])
@pytest.mark.parametrize("content_type", [
    "text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x",
    None, "application/jsonp", "text/json",
])
def test_a_body_not_sent_as_json_is_a_415(open_server: Server, path: str,
                                          content_type: str | None) -> None:
    # What a web page of another site may post to a local service without a preflight.
    headers = {"Content-Type": content_type} if content_type else {}
    with httpx.Client(base_url=open_server.url, timeout=30) as client:
        response = client.post(path, content=json.dumps(SMALL).encode(), headers=headers)
        assert response.status_code == 415, response.text
        assert response.headers["content-type"] == "application/problem+json"
        assert response.json()["type"].endswith("/unsupported-media-type")
        assert response.headers["accept-post"] == "application/json"
        assert client.get("/v1/layouts").json()["data"] == []  # nothing queued


@pytest.mark.slow
def test_json_with_a_charset_and_the_python_client_and_cli_still_get_through(
        open_server: Server, tmp_path: Path) -> None:
    import subprocess
    import sys

    from floorplan_client import Client

    with httpx.Client(base_url=open_server.url, timeout=30) as client:
        response = client.post("/v1/validate", content=json.dumps(SMALL).encode(),
                               headers={"Content-Type": "Application/JSON; charset=utf-8"})
        assert response.status_code == 200 and response.json()["valid"]
    with Client(open_server.url) as sdk:
        assert sdk.validate(SMALL).valid
        job = sdk.submit(SMALL)
        job.cancel()
    problem = tmp_path / "small.json"
    problem.write_text(json.dumps(SMALL))
    done = subprocess.run([sys.executable, "-m", "floorplan.service", "submit", str(problem),
                           "--server", open_server.url, "-q"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    with httpx.Client(base_url=open_server.url, timeout=60) as client:
        for listed in client.get("/v1/layouts").json()["data"]:
            client.post(f"/v1/layouts/{listed['id']}/cancel")
            wait(client, listed["id"])


@pytest.mark.slow
@pytest.mark.parametrize("host", ["evil.example", "evil.example:8000", "localhost.evil.example",
                                  "127.0.0.1.nip.io", "0.0.0.0"])
def test_a_service_on_loopback_answers_only_to_loopback_names(open_server: Server,
                                                              host: str) -> None:
    # DNS rebinding: a name the attacker controls, pointed at 127.0.0.1.
    for path in ("/healthz", "/v1/layouts", "/"):
        response = httpx.get(open_server.url + path, headers={"Host": host}, timeout=30)
        assert response.status_code == 400, response.text
        assert response.headers["content-type"] == "application/problem+json"
        assert response.json()["type"].endswith("/untrusted-host")
    posted = httpx.post(open_server.url + "/v1/layouts", json=SMALL, headers={"Host": host},
                        timeout=30)
    assert posted.status_code == 400


@pytest.mark.slow
@pytest.mark.parametrize("host", ["localhost", "LOCALHOST:1234", "127.0.0.1", "[::1]:8000"])
def test_loopback_names_are_answered(open_server: Server, host: str) -> None:
    response = httpx.get(open_server.url + "/healthz", headers={"Host": host}, timeout=30)
    assert response.status_code == 200, response.text


@pytest.mark.slow
def test_the_allowed_hosts_are_a_setting(tmp_path: Path) -> None:
    server = Server(tmp_path, FLOORPLAN_ALLOWED_HOSTS="plans.example, *.plans.example",
                    **QUIET)
    # The start waits for /readyz on 127.0.0.1, no longer an allowed name: ask by hand.
    server.env["FLOORPLAN_ALLOWED_HOSTS"] += ",127.0.0.1"
    server.start()
    try:
        for host, status in (("plans.example", 200), ("eu.plans.example:443", 200),
                             ("localhost", 400), ("evil.example", 400)):
            response = httpx.get(server.url + "/healthz", headers={"Host": host}, timeout=30)
            assert response.status_code == status, (host, response.text)
    finally:
        server.stop()


# A store that cannot write is not ready, and takes nothing it would lose.


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """An 8 MB tmpfs: the finding was made with 3 MB (root is needed to mount it)."""
    import subprocess

    mount = tmp_path / "data"
    mount.mkdir()
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=8m", "tmpfs", str(mount)],
                          capture_output=True, text=True)
    if made.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {made.stderr.strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def fill(directory: Path) -> Path:
    """Write zeros into `directory` until its disk is full; the file written."""
    filler = directory / "filler"
    with open(filler, "wb") as out:
        try:
            while True:
                out.write(b"\0" * 65536)
                out.flush()
        except OSError:
            pass
    return filler


@pytest.mark.slow
def test_a_full_data_dir_is_not_ready_and_accepts_nothing(small_disk: Path,
                                                          tmp_path: Path) -> None:
    from tests.service.test_service import LONG

    log_path = tmp_path / "server.log"
    server = Server(small_disk, FLOORPLAN_MIN_FREE_BYTES=str(1 << 20), WORKERS="1",
                    FLOORPLAN_SUBDOMAIN_PROCESSES="1")
    with open(log_path, "wb") as log:
        server.start_logging(log)
    try:
        with httpx.Client(base_url=server.url, timeout=30) as client:
            done = client.post("/v1/layouts", json={**SMALL, "options": {"time_limit": 1}})
            wait(client, done.json()["id"])
            running = client.post("/v1/layouts", json={**LONG, "options": {"time_limit": 3}})
            wait(client, running.json()["id"], until={"running"})
            queued = client.post("/v1/layouts", json={**SMALL, "options": {"time_limit": 1}})
            assert queued.json()["status"] == "queued"
            filler = fill(small_disk)

            ready = client.get("/readyz")
            assert ready.status_code == 503
            assert ready.json()["status"] == "not ready"
            assert "FLOORPLAN_MIN_FREE_BYTES" in ready.json()["store"]
            refused = client.post("/v1/layouts", json=SMALL)
            assert refused.status_code == 503, refused.text
            assert refused.headers["content-type"] == "application/problem+json"
            assert refused.json()["type"].endswith("/store-unavailable")
            assert int(refused.headers["retry-after"]) > 0
            # Writes fail: a 503 problem, not a 500.
            for answer in (client.delete(f"/v1/layouts/{done.json()['id']}"),
                           client.post(f"/v1/layouts/{running.json()['id']}/cancel")):
                assert answer.status_code == 503, answer.text
                assert answer.headers["content-type"] == "application/problem+json"
            assert len(client.get("/v1/layouts").json()["data"]) == 3  # reads still work

            # The running job ends, and waits for the store to take its end (holding its
            # slot: the queued job waits too), without a traceback twice a second.
            time.sleep(6)
            text = log_path.read_text()
            assert text.count("Traceback") <= 2, text[-3000:]
            assert text.count("the end not recorded yet") <= 5, text[-3000:]

            filler.unlink()
            assert client.get("/readyz").status_code == 200
            again = client.post("/v1/layouts", json={**SMALL, "options": {"time_limit": 1}})
            assert again.status_code == 202
            # Nothing accepted is lost: the running job's end is recorded once it can
            # be, the queued job and the new one both run.
            for job in (running, queued, again):
                assert wait(client, job.json()["id"], timeout=90)["status"] == "succeeded"
    finally:
        server.stop()


@pytest.mark.slow
def test_the_dispatcher_backs_off_while_the_store_refuses_writes(
        small_disk: Path, caplog: pytest.LogCaptureFixture) -> None:
    # A queued job and a full disk: claiming it fails. The dispatcher logged a traceback
    # every 0.5 s; now one, then a line per try, each wait twice the last.
    import logging

    from floorplan.service.jobs.processes import Runner
    from floorplan.service.settings import Settings

    settings = Settings(data_dir=small_disk, workers=1, subdomain_processes=1)
    store = JobStore(settings.store_url)
    store.create(problem=json.dumps(SMALL), time_limit=1)
    filler = fill(small_disk)
    runner = Runner(store, settings)
    with caplog.at_level(logging.INFO, logger="floorplan.runner"):
        runner.start()
        try:
            deadline = time.monotonic() + 60
            while len(failures := [r for r in caplog.records
                                   if "dispatcher error" in r.getMessage()]) < 3:
                assert time.monotonic() < deadline, [r.getMessage() for r in failures]
                time.sleep(0.1)
            # Backing off: each wait twice the last (1, 2, 4 s), said and kept (it polled
            # every 0.5 s); a load on the machine only makes the gaps longer.
            said = [re.search(r"trying again in (\d+) s", r.getMessage()) for r in failures]
            assert [int(m.group(1)) if m else None for m in said[:3]] == [1, 2, 4]
            gaps = [b.created - a.created for a, b in itertools.pairwise(failures[:3])]
            assert gaps[0] >= 1 - 0.05 and gaps[1] >= 2 - 0.05, gaps
            assert sum(r.exc_info is not None for r in failures) == 1
            filler.unlink()
            deadline = time.monotonic() + 40
            # Claimed once the store takes writes, and said so.
            while store.count(JobStatus.QUEUED) or not any(
                    "working again" in r.getMessage() for r in caplog.records):
                assert time.monotonic() < deadline, "the dispatcher did not come back"
                time.sleep(0.5)
        finally:
            runner.stop()


# Per-key fairness, and explain calls that starve nothing.

FAIR_KEYS = ["alpha", "beta", "gamma", "delta"]


def bearer(key: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {key}"}


@pytest.fixture(scope="module")
def fair(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    server = Server(tmp_path_factory.mktemp("fair"), FLOORPLAN_API_KEYS=",".join(FAIR_KEYS),
                    FLOORPLAN_MAX_JOBS_PER_KEY="2", FLOORPLAN_QUEUE_LIMIT="4",
                    FLOORPLAN_MAX_STREAMS_PER_KEY="2", FLOORPLAN_MAX_STREAMS="3",
                    FLOORPLAN_MAX_EXPLAINS_PER_KEY="1", FLOORPLAN_EXPLAIN_PROCESSES="2",
                    **QUIET).start()
    yield server
    server.stop()


def assert_too_many(response: httpx.Response, variable: str) -> None:
    assert response.status_code == 429, response.text
    assert response.headers["content-type"] == "application/problem+json"
    assert int(response.headers["retry-after"]) > 0
    problem = response.json()
    assert problem["type"].startswith("/docs/problems/too-many-")
    assert variable in problem["detail"]


@pytest.mark.slow
def test_one_key_filling_its_quota_leaves_room_for_the_next(fair: Server) -> None:
    from tests.service.test_service import LONG

    with httpx.Client(base_url=fair.url, timeout=30) as client:
        jobs = [client.post("/v1/layouts", json=LONG, headers=bearer("alpha"))
                for _ in range(2)]
        assert [j.status_code for j in jobs] == [202, 202]
        assert_too_many(client.post("/v1/layouts", json=LONG, headers=bearer("alpha")),
                        "FLOORPLAN_MAX_JOBS_PER_KEY")
        other = client.post("/v1/layouts", json=SMALL, headers=bearer("beta"))
        assert other.status_code == 202, other.text
        # A finished job no longer counts.
        client.post(f"/v1/layouts/{jobs[0].json()['id']}/cancel", headers=bearer("alpha"))
        for job, key in ((jobs[0], "alpha"), (jobs[1], "alpha"), (other, "beta")):
            wait_keyed(client, job.json()["id"], key, cancel=True)
        again = client.post("/v1/layouts", json=SMALL, headers=bearer("alpha"))
        assert again.status_code == 202
        wait_keyed(client, again.json()["id"], "alpha", cancel=True)


def wait_keyed(client: httpx.Client, job_id: str, key: str, cancel: bool = False) -> None:
    if cancel:
        client.post(f"/v1/layouts/{job_id}/cancel", headers=bearer(key))
    deadline = time.monotonic() + 60
    while client.get(f"/v1/layouts/{job_id}", headers=bearer(key)).json()["status"] in (
            "queued", "running"):
        assert time.monotonic() < deadline
        time.sleep(0.2)


@pytest.mark.slow
def test_open_event_streams_are_limited_per_key_and_in_all(fair: Server) -> None:
    from tests.service.test_service import LONG

    with httpx.Client(base_url=fair.url, timeout=30) as client:
        mine = client.post("/v1/layouts", json=LONG, headers=bearer("alpha")).json()["id"]
        theirs = client.post("/v1/layouts", json=LONG, headers=bearer("beta")).json()["id"]
        try:
            def open_stream(job_id: str, key: str) -> Any:
                return client.stream("GET", f"/v1/layouts/{job_id}/events",
                                     headers=bearer(key))

            with open_stream(mine, "alpha") as first, open_stream(mine, "alpha") as second:
                assert first.status_code == second.status_code == 200
                refused = client.get(f"/v1/layouts/{mine}/events", headers=bearer("alpha"))
                assert_too_many(refused, "FLOORPLAN_MAX_STREAMS_PER_KEY")
                with open_stream(theirs, "beta") as third:
                    assert third.status_code == 200  # another key's first stream
                    assert_too_many(client.get(f"/v1/layouts/{theirs}/events",
                                               headers=bearer("beta")), "FLOORPLAN_MAX_STREAMS")
            # Closed streams are given back.
            deadline = time.monotonic() + 60
            while True:
                with open_stream(mine, "alpha") as s1, open_stream(mine, "alpha") as s2, \
                        open_stream(theirs, "beta") as s3:
                    if [s.status_code for s in (s1, s2, s3)] == [200] * 3:
                        break
                assert time.monotonic() < deadline, "closed streams still counted"
                time.sleep(0.5)
        finally:
            wait_keyed(client, mine, "alpha", cancel=True)
            wait_keyed(client, theirs, "beta", cancel=True)


#: Infeasible by packing (12 rooms of at least 3.3 x 3.3 m in 16 x 9 m): explain's
#: conflict search runs for seconds.
TIGHT: dict[str, Any] = {
    "boundary": [[0, 0], [16, 0], [16, 9], [0, 9]],
    "rooms": [{"id": f"o{k}", "min_size": [3.3, 3.3], "max_size": [6, 6]} for k in range(12)],
}


@pytest.mark.slow
def test_explain_calls_are_limited_per_key_and_starve_nothing(fair: Server) -> None:
    answers: dict[str, httpx.Response] = {}

    def explain(key: str) -> None:
        answers[key] = httpx.post(f"{fair.url}/v1/validate", json=TIGHT, headers=bearer(key),
                                  params={"explain": "true", "time_limit": "6"}, timeout=60)

    with httpx.Client(base_url=fair.url, timeout=30) as client:
        job = client.post("/v1/layouts", json=SMALL, headers=bearer("alpha")).json()["id"]
        wait_keyed(client, job, "alpha")
        calls = [threading.Thread(target=explain, args=(key,)) for key in FAIR_KEYS]
        for call in calls:
            call.start()
        # A second call of alpha's while its first is in flight: on a fast machine an
        # explanation of TIGHT takes about a second, so at 0.5 s the thread's call is
        # being explained and this one is refused; on a busy one the thread's request
        # may reach the server after this one, which then holds the slot, and the
        # thread's is refused. Either way one of the two is a 429.
        time.sleep(0.5)
        fifth = client.post("/v1/validate", json=TIGHT, headers=bearer("alpha"),
                            params={"explain": "true"})
        slowest = {"healthz": 0.0, "validate": 0.0, "events": 0.0}
        rounds = 0
        while any(call.is_alive() for call in calls):
            rounds += 1
            for name, call in (
                    ("healthz", lambda: client.get("/healthz")),
                    ("validate", lambda: client.post("/v1/validate", json=SMALL,
                                                     headers=bearer("beta"))),
                    ("events", lambda: client.get(f"/v1/layouts/{job}/events",
                                                  headers=bearer("alpha")))):
                started = time.monotonic()
                assert call().status_code == 200
                slowest[name] = max(slowest[name], time.monotonic() - started)
            time.sleep(0.1)
        for call in calls:
            call.join()
    pair = [answers["alpha"], fifth]
    assert sorted(r.status_code for r in pair) == [200, 429], [r.text for r in pair]
    assert_too_many(next(r for r in pair if r.status_code == 429),
                    "FLOORPLAN_MAX_EXPLAINS_PER_KEY")
    explained = [answers[key] for key in FAIR_KEYS if answers[key].status_code == 200]
    assert [answers[key].status_code for key in FAIR_KEYS[1:]] == [200] * 3
    # Infeasible: proved so, or left open when the time ran out; never feasible.
    assert all(r.json()["feasible"] is not True for r in explained)
    # Nothing waited for an explanation (in a process of its own): every call was
    # answered in less than half the time the quickest explanation took, and calls were
    # answered all along. Against the explanations, not seconds: both grow on a busy
    # machine (0.2 s for /healthz and 1 s for the others on an idle one).
    quickest = min(r.elapsed.total_seconds() for r in explained)
    assert max(slowest.values()) < quickest / 2, (slowest, quickest)
    assert rounds >= 3, rounds
