"""docker-compose.yml and the Dockerfile, checked without a Docker engine (none runs
on our machines): the topology, its health checks and volumes, and that every command,
setting and file they name exists here. scripts/run-distributed.sh starts the same
topology from plain processes and is run in test_run_script.py."""

from __future__ import annotations

import re
import subprocess
import sys
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


def test_workers_scale_and_stop_gracefully() -> None:
    services = compose()["services"]
    for name, command in (("worker", ["floorplan", "worker"]),
                          ("subdomain-worker", ["floorplan", "worker", "--subdomains"])):
        worker = services[name]
        # --scale NAME=N needs no fixed name and no host port.
        assert "container_name" not in worker and "ports" not in worker
        assert worker["command"] == command
        assert worker["healthcheck"]["test"] == ["CMD", *command, "--health"]
        assert worker["stop_grace_period"]  # time to hand running jobs back
    assert services["worker"]["environment"]["FLOORPLAN_SUBDOMAINS"] == "celery"


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
