"""docker-compose.yml and the Dockerfile, read without a Docker engine: the topology, its
health checks and volumes, and that every command, setting and file they name exists
here. deploy/test-compose.sh builds and runs them on a real engine (in CI, after this
suite); scripts/run-distributed.sh starts the same topology from plain processes and is
run in test_run_script.py."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path
from typing import Any

import yaml

from floorplan.service.settings import Settings
from tests.paths import ROOT


def compose() -> dict[str, Any]:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def test_compose_has_the_four_services_with_health_checks_and_volumes() -> None:
    spec = compose()
    services = spec["services"]
    assert set(services) == {"api", "worker", "subdomain-worker", "redis", "postgres"}
    for name, service in services.items():
        assert service["healthcheck"]["test"], name
    used = {mount.split(":")[0] for s in services.values() for mount in s.get("volumes", [])}
    assert used == set(spec["volumes"]) == {"postgres-data", "redis-data"}
    for node in ("api", "worker"):
        waits = services[node]["depends_on"]
        assert waits == {"postgres": {"condition": "service_healthy"},
                         "redis": {"condition": "service_healthy"}}


def test_redis_asks_for_the_password_the_nodes_send() -> None:
    # Whoever can write to Redis queues work for the workers (docs/security.md).
    services = compose()["services"]
    redis = services["redis"]
    password = "${REDIS_PASSWORD:-floorplan}"
    assert redis["command"][-2:] == ["--requirepass", password]
    assert password in redis["healthcheck"]["test"]
    for node in ("api", "worker", "subdomain-worker"):
        url = services[node]["environment"]["FLOORPLAN_REDIS_URL"]
        assert url.startswith(f"redis://:{password}@redis:6379/"), node


HEALTH = ["python", "-m", "floorplan.service.jobs.broker.health"]


def test_workers_scale_and_stop_gracefully() -> None:
    services = compose()["services"]
    subdomains = ["floorplan", "worker", "--subdomains"]
    for name, command, health in (("worker", ["floorplan", "worker"], HEALTH),
                                  ("subdomain-worker", subdomains, [*HEALTH, "--subdomains"])):
        worker = services[name]
        # --scale NAME=N needs no fixed name and no host port.
        assert "container_name" not in worker and "ports" not in worker
        assert worker["command"] == command
        assert worker["healthcheck"]["test"] == ["CMD", *health]
        assert worker["stop_grace_period"]  # time to hand running jobs back
    assert services["worker"]["environment"]["FLOORPLAN_SUBDOMAINS"] == "celery"


def test_one_service_builds_the_image_the_others_run() -> None:
    # One build per `up --build`: a build on each service made one image per service, and
    # scaling then recreated every container whose image had changed under it.
    services = compose()["services"]
    assert [name for name, s in services.items() if "build" in s] == ["api"]
    for name in ("api", "worker", "subdomain-worker"):
        assert services[name]["image"] == "floorplan:latest", name
    for name in ("worker", "subdomain-worker"):
        assert services[name]["pull_policy"] == "never", name


def test_the_api_is_published_on_loopback_unless_told_otherwise() -> None:
    # FLOORPLAN_API_KEYS is empty by default: an API without keys stays on this host.
    assert compose()["services"]["api"]["ports"] == [
        "${FLOORPLAN_BIND:-127.0.0.1}:${FLOORPLAN_PORT:-8000}:8000"]


def test_the_image_declares_no_volume() -> None:
    # A VOLUME gives every container of the image an anonymous volume, the workers' too,
    # which `docker compose down -v` leaves behind.
    assert not re.search(r"^VOLUME", (ROOT / "Dockerfile").read_text(), re.MULTILINE)


def test_every_floorplan_variable_in_compose_is_a_setting() -> None:
    fields = {f"FLOORPLAN_{name.upper()}" for name in Settings.model_fields}
    services = compose()["services"]
    for node in ("api", "worker", "subdomain-worker"):
        env = services[node]["environment"]
        assert env["FLOORPLAN_BACKEND"] == "celery"
        assert env["FLOORPLAN_DATABASE_URL"].startswith("postgresql+psycopg://")
        assert set(env) <= fields, set(env) - fields


def test_the_commands_compose_runs_exist() -> None:
    api = compose()["services"]["api"]["command"]
    assert api[:2] == ["uvicorn", "floorplan.service.api.app:create_app"] and "--factory" in api
    for argv in (["-m", "floorplan.service", "worker", "--help"], ["-m", "uvicorn", "--help"]):
        subprocess.run([sys.executable, *argv], check=True, capture_output=True)


def test_the_worker_health_check_imports_the_standard_library_only() -> None:
    # It runs every 15 s beside the solves, under a 5 s timeout: importing the Celery
    # worker module took seconds on a busy machine, and even the Redis client and the
    # settings (0.4 s of CPU) took it past 5 s beside a running solve.
    code = textwrap.dedent("""
        import runpy, sys
        sys.argv = ["health"]
        try:
            runpy.run_module("floorplan.service.jobs.broker.health", run_name="__main__")
        except SystemExit:
            pass
        heavy = ("celery", "kombu", "redis", "pydantic", "pyscipopt", "numpy", "shapely",
                 "floorplan.solver", "floorplan.models", "floorplan.service.settings")
        print([m for m in sys.modules if m.startswith(heavy)])
    """)
    # A Redis that nobody listens on: the check answers "not alive" (1) quickly.
    env = {**os.environ, "FLOORPLAN_REDIS_URL": "redis://127.0.0.1:9/0"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, check=True)
    assert done.stdout.strip() == "[]", done.stdout


def test_the_install_hints_name_the_package_on_pypi() -> None:
    # "floorplan" on PyPI is another project; ours is floorplan-miqp.
    name = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["name"]
    assert name == "floorplan-miqp"
    for path in [ROOT / "README.md", *(ROOT / "docs").glob("*.md"),
                 *(ROOT / "service").rglob("*.py"), *(ROOT / "clients").rglob("*.md")]:
        assert "floorplan[" not in path.read_text(), path


def test_the_dockerfile_copies_files_that_exist_and_installs_the_distributed_extra() -> None:
    dockerfile = (ROOT / "Dockerfile").read_text()
    for line in re.findall(r"^COPY (.+)$", dockerfile, re.MULTILINE):
        *sources, _target = line.split()
        for source in sources:
            assert (ROOT / source).exists(), source
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert 'pip install ".[distributed]"' in dockerfile and "distributed" in extras
    ignored = (ROOT / ".dockerignore").read_text().split()
    assert not {"models", "solver", "service", "examples"} & set(ignored)
    # Every link in the copied packages points at something copied too.
    copied = {Path(line.split()[1]).name for line in re.findall(r"^COPY (.+)$", dockerfile,
                                                                   re.MULTILINE)}
    for link in (p for p in (ROOT / "service").rglob("*") if p.is_symlink()):
        assert link.resolve().relative_to(ROOT).parts[0] in copied, link
