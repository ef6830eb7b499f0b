"""Session-wide clean-up of what the distributed-mode tests create in the machine's
PostgreSQL (a schema per cluster in the test database) and Redis (a namespace each)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests import servers


@pytest.fixture(scope="session", autouse=True)
def _forget_distributed_test_data() -> Iterator[None]:
    yield
    if servers.created_namespaces:
        servers.forget_namespaces(servers.REDIS_URL, servers.created_namespaces)
    if servers.created_schemas:
        servers.drop_schemas(servers.created_schemas)
