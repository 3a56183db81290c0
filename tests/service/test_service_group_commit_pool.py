"""Group commit and the connection pool: the cause of the 500s after a restart.

After a restart the device key cache is cold, so every request's session looks its key up and
then holds that connection (idle in a transaction) while it waits for its group's commit. With
as many waiting requests as the pool has connections, the group commit itself found no
connection, the pool timed out, and every waiting device was answered 500. Here the pool has one
connection, which makes that deterministic: the request's look-up takes it, the group needs it.
A device must hear 201 (the request gives its connection back before it waits for the group),
and when the pool is really exhausted, 503 problem+json with Retry-After, never 500.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, create_engine, func, select

from core.settings import get_settings
from ingest.models import RawEvent
from tests.conftest import app_on
from tests.service.linekit import build_line, event


@pytest.fixture
def one_connection(engine: Engine, monkeypatch: pytest.MonkeyPatch) -> Iterator[Engine]:
    """An engine on the test database with a pool of one connection, a cold key cache on
    every request (TTL 0, as right after a restart) and group commit on."""
    if engine.dialect.name != "postgresql":
        pytest.skip("group commit runs on PostgreSQL only")
    monkeypatch.setenv("DEPOT_DEVICE_KEY_TTL_S", "0")
    monkeypatch.setenv("DEPOT_GROUP_COMMIT_MS", "2")
    get_settings.cache_clear()
    small = create_engine(engine.url, pool_size=1, max_overflow=0, pool_timeout=1)
    yield small
    small.dispose()
    get_settings.cache_clear()
    from service.models import metadata

    with engine.begin() as connection:
        for table in reversed(metadata.sorted_tables):
            connection.execute(table.delete())


def _client(engine: Engine) -> Any:
    return TestClient(app_on(engine), raise_server_exceptions=False)


def test_a_waiting_request_leaves_its_connection_to_the_group(one_connection: Engine) -> None:
    with _client(one_connection) as client:
        keys = build_line(client)
        body = event("pool-1", "axle_count", section="AB", axles=212)
        response = client.post("/api/v1/events", json=body, headers=keys["B-ac"])
        assert response.status_code == 201, response.text
        again = client.post("/api/v1/events", json=body, headers=keys["B-ac"])
        assert again.status_code == 200 and again.json()["status"] == "duplicate"
    with one_connection.connect() as connection:
        assert connection.scalar(select(func.count()).select_from(RawEvent)) == 1


def test_an_exhausted_pool_answers_503_with_retry_after(one_connection: Engine) -> None:
    with _client(one_connection) as client:
        keys = build_line(client)
        body = event("pool-2", "axle_count", section="AB", axles=212)
        with one_connection.connect():  # someone else holds the only connection
            response = client.post("/api/v1/events", json=body, headers=keys["B-ac"])
        assert response.status_code == 503, response.text
        assert response.headers["content-type"] == "application/problem+json"
        assert "retry-after" in response.headers
        retried = client.post("/api/v1/events", json=body, headers=keys["B-ac"])
        assert retried.status_code == 201, retried.text
