"""What the fleet tests share: the line with its parameter bands, an engineer, the CSV
header, refusals of the importer, the measurement count, and a database per migration test."""

from __future__ import annotations

import io
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from core.errors import Unprocessable
from service.fleet.importing import parse_tests
from service.fleet.models import Measurement
from service.fleet.rules import registered
from service.setup.service import create_user
from tests.conftest import POSTGRES_URL
from tests.service.linekit import build_line, register_bands
from tests.service.scratchdb import scratch_database

T0 = datetime(2026, 11, 1, 7, 30, tzinfo=UTC)
HEADER = "car,taken_at,door_close_s,brake_release_s\n"


@pytest.fixture
def keys(client: TestClient) -> dict[str, dict[str, str]]:
    """The line's device keys, the door and brake parameters registered with their bands."""
    keys = build_line(client)
    register_bands(client)
    return keys


@pytest.fixture
def engineer(session: Session) -> dict[str, str]:
    token = create_user(session, "iryna", "engineer")
    session.commit()
    return {"Authorization": f"Bearer {token}"}


def refusal(session: Session, text: str) -> str:
    """The importer's refusal of the CSV ``text`` (fails the test when it is accepted)."""
    with pytest.raises(Unprocessable) as refused:
        parse_tests(io.StringIO(text), registered(session))
    return refused.value.detail


def measurement_count(session: Session) -> int:
    return session.scalar(select(func.count()).select_from(Measurement)) or 0


@pytest.fixture(params=["sqlite", "postgresql"])
def url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    """An empty database for a migration test: a file, or this run's own on the test server."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'migration.sqlite3'}"
        return
    if not POSTGRES_URL:
        pytest.skip("DEPOT_TEST_POSTGRES_URL is not set; PostgreSQL tests skipped")
    with scratch_database("migration") as scratch:
        yield scratch
