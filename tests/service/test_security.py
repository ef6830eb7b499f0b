"""The security review (issue 20), each finding replayed against a real server process
on loopback (tests/servers.py), the machine's PostgreSQL or Redis: what an attacker did
must now fail."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx2 as httpx
import pytest

from tests.servers import Server
from tests.service.test_service import SMALL

#: End to end (real server processes on loopback): left out by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow

KEY = {"Authorization": "Bearer alpha"}


@pytest.fixture(scope="module")
def keyed(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    server = Server(tmp_path_factory.mktemp("keyed"), FLOORPLAN_API_KEYS="alpha",
                    WORKERS="1").start()
    yield server
    server.stop()


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


def test_without_keys_readyz_and_validate_are_open_as_before(tmp_path: Path) -> None:
    server = Server(tmp_path, WORKERS="1").start()
    try:
        with httpx.Client(base_url=server.url, timeout=30) as client:
            ready = client.get("/readyz").json()
            assert ready["status"] == "ready" and ready["queued"] == 0
            assert client.post("/v1/validate", json=SMALL).json()["valid"]
    finally:
        server.stop()
