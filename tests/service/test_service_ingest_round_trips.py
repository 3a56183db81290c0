"""Round trips of the ingest path: what a group of events asks the database, counted.

No timing here (a shared machine): the number and kind of statements a group of events sends,
which is what decides its cost once the database is the bottleneck.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import event as sa_event
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from core.models import Device
from ingest import service
from ingest.holding import held, holding
from ingest.models import RawEvent
from service.clearance.models import AxleReading
from tests.service.linekit import build_line, event


@pytest.fixture
def statements(session: Session) -> Iterator[list[str]]:
    """Every SQL statement ``session``'s connection sends while the test runs."""
    seen: list[str] = []
    connection = session.connection()

    def _record(conn: Any, cursor: Any, statement: str, *_: Any) -> None:
        seen.append(" ".join(statement.split()))

    sa_event.listen(connection, "before_cursor_execute", _record)
    yield seen
    sa_event.remove(connection, "before_cursor_execute", _record)


def _axle_counts(session: Session, n: int, prefix: str) -> list[tuple[Device, Any, dict[str, Any]]]:
    device = session.get_one(Device, "B-ac")
    items = []
    for i in range(n):
        body = event(f"{prefix}-{i}", "axle_count", section="AB", axles=4 * i)
        items.append((device, service.validate_event(device, body), body))
    return items


def test_a_group_of_one_section_reads_the_section_once(
    client: TestClient, session: Session, statements: list[str]
) -> None:
    build_line(client)
    items = _axle_counts(session, 12, "rt")
    statements.clear()
    outcomes = service.store_group(session, items)
    assert [o[0] for o in outcomes if isinstance(o, tuple)] == [201] * 12
    section_reads = [s for s in statements if s.startswith("SELECT") and "FROM sections" in s]
    # The lock (SELECT … FOR UPDATE on PostgreSQL) once; the later events find the locked row
    # in the session instead of reading it again.
    assert len(section_reads) == 1, section_reads
    assert session.scalar(select(func.count()).select_from(AxleReading)) == 12
    assert session.scalar(select(func.count()).select_from(RawEvent)) == 12


def test_holding_keeps_loaded_rows_only_inside_the_block(
    client: TestClient, session: Session
) -> None:
    build_line(client)
    with holding(session):
        session.scalars(select(Device)).all()
        assert held(session) > 0
        with holding(session):  # nested: the outer block still owns what is held
            pass
        assert held(session) > 0
    assert held(session) == 0
