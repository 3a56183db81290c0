"""API fuzzing with schemathesis against the app's own OpenAPI document.

Every documented operation gets generated requests (valid and invalid): no 5xx, and every
response (including the 422 problem+json bodies) conforms to the document.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from core.database import make_engine
from service.migrate import upgrade
from tests.conftest import ADMIN, app_on
from tests.reliability.matrix import ENDPOINTS
from tests.reliability.relkit import SOAK
from tests.service.linekit import build_line

EXAMPLES = 100 if SOAK else 15
DEVICE_PATHS = {"/api/v1/events": "B-ac", "/api/v1/snapshots": "B-cam"}


@pytest.fixture(scope="module")
def fuzz_app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Any, dict[str, Any]]]:
    """The app on its own committed SQLite database with the small line built."""
    url = f"sqlite:///{Path(tmp_path_factory.mktemp('schema')) / 'fuzz.sqlite3'}"
    upgrade(url)
    engine = make_engine(url)
    app = app_on(engine)
    with TestClient(app) as client:
        keys = build_line(client)
    yield app, keys
    engine.dispose()


OPERATIONS = [(m, p) for m, p, _ in ENDPOINTS]


def _fuzz(fuzz_app: tuple[Any, dict[str, Any]], method: str, path: str, checks: list[Any]) -> None:
    app, keys = fuzz_app
    operation = schemathesis.openapi.from_asgi("/openapi.json", app).find_operation_by_path(
        method, path
    )
    if operation is None:
        pytest.skip(f"{method} {path} is not served yet")
    headers = keys[DEVICE_PATHS[path]] if path in DEVICE_PATHS else ADMIN

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        database=None,
        derandomize=not SOAK,
        suppress_health_check=list(HealthCheck),
    )
    @given(case=operation.as_strategy())
    def check(case: Any) -> None:
        case.call_and_validate(headers=headers, checks=checks)

    check()


@pytest.mark.parametrize(("method", "path"), OPERATIONS)
def test_no_server_error_and_documented_bodies_conform(
    fuzz_app: tuple[Any, dict[str, Any]], method: str, path: str
) -> None:
    _fuzz(fuzz_app, method, path, [not_a_server_error, response_schema_conformance])


def test_every_status_and_content_type_is_documented(
    fuzz_app: tuple[Any, dict[str, Any]],
) -> None:
    """One sweep with few examples: the document's promises cover what the service answers."""
    undocumented = []
    for method, path in OPERATIONS:
        try:
            _fuzz(fuzz_app, method, path, [status_code_conformance, content_type_conformance])
        except (Exception, BaseExceptionGroup) as exc:
            undocumented.append(f"{method} {path}: {str(exc)[:300]}")
    assert not undocumented, "\n".join(undocumented)
