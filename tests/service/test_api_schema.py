"""A bounded schemathesis run over the OpenAPI schema of a live server, in both modes
(embedded, and an API node with a Celery worker): no 5xx, and every response conforms
to the schema it documents. (schemathesis's pytest plugin
does not support pytest 9 yet, so its strategies are driven with hypothesis here.)"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from schemathesis import checks

from tests.servers import BACKENDS, service

#: End to end (real server processes on loopback): left out by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow

#: What the service promises of every response. Not "schema-valid data is accepted":
#: cross-field rules (an axis-aligned outline, known room ids) are beyond JSON Schema,
#: so a schema-valid body may rightly get a 422.
CHECKS = [
    checks.not_a_server_error,
    checks.response_schema_conformance,
    checks.content_type_conformance,
]
#: Examples per operation: enough to hit every parameter's edges, bounded in time.
EXAMPLES = 15


@pytest.fixture(scope="module", params=BACKENDS)
def api_schema(request: pytest.FixtureRequest,
               tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    # Short solves: generated problems that happen to be valid must not pile up.
    server = service(request.param, tmp_path_factory.mktemp("fuzz"),
                     FLOORPLAN_MAX_TIME_LIMIT="1", WORKERS="1").start()
    try:
        yield schemathesis.openapi.from_url(f"{server.url}/openapi.json")
    finally:
        server.stop()


def operations(schema: Any) -> list[Any]:
    found = [result.ok() for result in schema.get_all_operations()]
    # The event stream stays open while its job runs; its schema is a content type only.
    return [op for op in found if not op.path.endswith("/events")]


def test_every_operation_answers_within_its_schema_and_never_5xx(api_schema: Any) -> None:
    ops = operations(api_schema)
    assert len(ops) >= 8
    for op in ops:

        @settings(max_examples=EXAMPLES, deadline=None, database=None,
                  suppress_health_check=list(HealthCheck))
        @given(case=op.as_strategy())
        def call(case: schemathesis.Case) -> None:
            case.call_and_validate(checks=CHECKS)

        call()
