"""Round trips of the ingest path: what a group of events asks the database, counted.

No timing here (a shared machine): the number and kind of statements a group of events sends,
which is what decides its cost once the database is the bottleneck.
"""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import event as sa_event
from sqlalchemy import func, select, update
from sqlalchemy.orm import Session

from core.models import Device
from ingest import liveness, service
from ingest.holding import held, holding
from ingest.models import RawEvent
from service.clearance.models import AxleReading
from tests.service.linekit import build_line, event


@pytest.fixture
def statements(session: Session) -> Iterator[list[str]]:
    """Every SQL statement ``session``'s connection sends while the test runs."""
    seen: list[str] = []
    connection = session.connection()

    def _record(conn: Any, cursor: Any, statement: str, parameters: Any, *_: Any) -> None:
        seen.append(" ".join(statement.split()) + f" -- {parameters}")

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
    # Only this test's events: the database may hold other tests' committed rows.
    ours = select(func.count()).select_from(RawEvent).where(RawEvent.event_id.like("rt-%"))
    assert session.scalar(ours) == 12


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


def test_a_group_locks_its_sections_before_any_device_row_in_device_order(
    client: TestClient, session: Session, statements: list[str]
) -> None:
    """Two workers' groups (or a group and a single event) must take row locks in one order,
    else each waits for the other's device or section row: a deadlock, which costs the
    database's deadlock timeout and a retry of every event of the group."""
    build_line(client)
    b_ac, a_ac = session.get_one(Device, "B-ac"), session.get_one(Device, "A-ac")
    items = []
    for i, device in enumerate((b_ac, a_ac, b_ac, a_ac)):
        body = event(f"lo-{i}", "axle_count", section="AB", axles=4)
        items.append((device, service.validate_event(device, body), body))
    statements.clear()
    service.store_group(session, items)
    lock = next(i for i, s in enumerate(statements) if "FROM sections" in s)
    touched = [i for i, s in enumerate(statements) if s.startswith("UPDATE devices")]
    assert len(touched) == 2 and min(touched) > lock, statements
    order = ["A-ac" if "A-ac" in statements[i] else "B-ac" for i in touched]
    assert order == ["A-ac", "B-ac"], statements
    seen = session.scalars(select(Device.last_seen_at).where(Device.id.in_(["A-ac", "B-ac"])))
    assert all(at is not None for at in seen)


def test_a_batch_sent_again_is_answered_with_one_look_up(
    client: TestClient, session: Session, statements: list[str]
) -> None:
    """A device that lost the answer to a batch sends it again: every item is answered as a
    duplicate with its original result, and a reused id with another body is refused, from
    one look-up of the stored events, not one per event."""
    build_line(client)
    device = session.get_one(Device, "B-ac")
    items = [event(f"again-{i}", "axle_count", section="AB", axles=4 * i) for i in range(20)]
    first = service.accept_batch(session, device, items)
    assert [r["status"] for r in first] == ["created"] * 20
    changed = [*items[:-1], {**items[-1], "axles": 999}]
    statements.clear()
    again = service.accept_batch(session, device, changed)
    assert [r["status"] for r in again] == ["duplicate"] * 19 + ["rejected"]
    assert [r["result"] for r in again[:19]] == [
        {**r["result"], "status": "duplicate"} for r in first[:19]
    ]
    assert again[-1]["error"]["status"] == 409
    look_ups = [s for s in statements if s.startswith("SELECT") and "FROM raw_events" in s]
    assert len(look_ups) == 1, look_ups


def test_a_group_answers_retries_from_one_look_up(
    client: TestClient, session: Session, statements: list[str]
) -> None:
    build_line(client)
    items = _axle_counts(session, 6, "gr")
    service.store_group(session, items)
    statements.clear()
    outcomes = service.store_group(session, [*items, items[0]])
    assert [o[0] for o in outcomes if isinstance(o, tuple)] == [200] * 7
    look_ups = [s for s in statements if s.startswith("SELECT") and "FROM raw_events" in s]
    assert len(look_ups) <= 2, look_ups  # the group's, and the one for the repeat inside it


def test_a_device_another_worker_kept_alive_costs_one_liveness_write_per_batch(
    client: TestClient, session: Session, statements: list[str]
) -> None:
    """Another worker moved the device's ``last_seen_at`` a moment ago, so this worker's
    conditional update does not match: what it learns then must spare the batch's other
    events their own update (it asked the database once for each of the 50 events)."""
    build_line(client)
    device = session.get_one(Device, "B-ac")
    moments_ago = datetime.now(UTC) - timedelta(seconds=2)
    session.execute(update(Device).where(Device.id == "B-ac").values(last_seen_at=moments_ago))
    liveness._known.clear()  # what this worker learnt: nothing (the other worker wrote it)
    items = [event(f"kept-{i}", "heartbeat") for i in range(50)]
    statements.clear()
    results = service.accept_batch(session, device, items)
    assert [r["status"] for r in results] == ["created"] * 50
    touches = [s for s in statements if s.startswith("UPDATE devices")]
    reads = [s for s in statements if "last_seen_at" in s and s.startswith("SELECT")]
    assert len(touches) + len(reads) <= 2, touches
    # The rule is unchanged: the stored value was within one step, so it stays.
    assert session.scalar(select(Device.last_seen_at).where(Device.id == "B-ac")) == moments_ago
