"""What single axle counts cost the database in a group commit: the readings go in together.

Counted as the server executes them: every parameter set of an executemany is one execution
(psycopg sends them in one pipeline, but PostgreSQL parses, plans and runs each one). No
timing here (a shared machine); the count is what decides the cost once the database, or the
worker's Python driving it, is the bottleneck.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import event as sa_event
from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Device
from ingest import service
from ingest.models import RawEvent
from service.clearance.models import AxleReading
from tests.service.linekit import build_line, event

# What a group of axle counts of one section may send besides one answer update per event
# (prepared and pipelined, which measured cheaper for PostgreSQL than one UPDATE from a JSON
# document): the raw rows, the section lock, the section's runs, the readings, and the
# liveness of each of the group's (two) devices, which may need a read of the stored value
# when another event moved it.
PER_GROUP = 8


def _allowed(n: int) -> int:
    return PER_GROUP + n


@pytest.fixture
def executions(session: Session) -> Iterator[list[str]]:
    """One entry per statement execution on ``session``'s connection (PostgreSQL only: the
    group commit runs only there)."""
    if session.get_bind().dialect.name != "postgresql":
        pytest.skip("the group commit runs on PostgreSQL only")
    seen: list[str] = []
    connection = session.connection()

    def _record(
        conn: Any, cursor: Any, statement: str, parameters: Any, context: Any, many: bool
    ) -> None:
        text = " ".join(statement.split())[:60]
        # An executemany sends a list of parameter sets; a multi-row INSERT one flat set.
        runs = len(parameters) if many and isinstance(parameters, list | tuple) else 1
        seen.extend([text] * runs)

    sa_event.listen(connection, "before_cursor_execute", _record)
    yield seen
    sa_event.remove(connection, "before_cursor_execute", _record)


def _counts(session: Session, prefix: str, n: int) -> list[tuple[Device, Any, dict[str, Any]]]:
    """``n`` axle counts of section AB from both of its counters, a few seconds apart, with
    the miscounts a real counter makes (a wheel missed, one counted twice)."""
    counters = [session.get_one(Device, "A-ac"), session.get_one(Device, "B-ac")]
    items = []
    for i in range(n):
        device = counters[i % 2]
        axles = 24 + (-1 if i % 7 == 3 else 1 if i % 11 == 5 else 0)
        body = event(f"{prefix}-{i}", "axle_count", f"2026-11-23T10:{i // 6:02d}:{i % 60:02d}Z")
        body.update(section="AB", axles=axles)
        items.append((device, service.validate_event(device, body), body))
    return items


def _group(session: Session, items: list[Any], executions: list[str]) -> list[Any]:
    executions.clear()
    outcomes = service.store_group(session, items)
    session.commit()  # the committer's commit: the section lock and its cache end here
    return outcomes


def _reading_inserts(executions: list[str]) -> int:
    return sum(text.startswith("INSERT INTO axle_readings") for text in executions)


def _stored_answers(session: Session, prefix: str) -> dict[str, dict[str, Any]]:
    rows = session.execute(
        select(RawEvent.event_id, RawEvent.result).where(RawEvent.event_id.like(f"{prefix}-%"))
    )
    return {event_id: result for event_id, result in rows}


def test_a_group_of_axle_counts_inserts_its_readings_with_one_statement(
    client: TestClient, session: Session, executions: list[str]
) -> None:
    build_line(client)
    for prefix, n in (("small", 4), ("large", 40)):
        outcomes = _group(session, _counts(session, prefix, n), executions)
        assert [o[0] for o in outcomes] == [201] * n
        assert len(executions) <= _allowed(n), (n, Counter(executions))
        assert _reading_inserts(executions) == 1, Counter(executions)
        # What each device was told is what is stored: a retry gets the same answer.
        stored = _stored_answers(session, prefix)
        assert stored == {o[1]["event_id"]: o[1] for o in outcomes}
        assert all(o[1]["run"] is None and "evidence kept" in o[1]["note"] for o in outcomes)
    readings = session.scalars(select(AxleReading.axles).where(AxleReading.section == "AB"))
    assert len(list(readings)) == 44


def test_counts_joining_a_running_train_go_in_together(
    client: TestClient, session: Session, executions: list[str]
) -> None:
    build_line(client)
    interlocking = session.get_one(Device, "A-ilk")
    departure = event("dep-1", "train_departed", "2026-11-23T09:59:30Z", section="AB")
    departure["train"] = "4711"
    _group(session, [(interlocking, service.validate_event(interlocking, departure), departure)],
           executions)  # fmt: skip
    items = _counts(session, "run", 30)
    outcomes = _group(session, items, executions)
    assert len(executions) <= _allowed(len(items)), Counter(executions)
    assert _reading_inserts(executions) == 1, Counter(executions)
    run_id = session.scalar(select(RawEvent.id).where(RawEvent.event_id == "dep-1"))
    assert {o[1]["run"] for o in outcomes} == {run_id}
    assert _stored_answers(session, "run") == {o[1]["event_id"]: o[1] for o in outcomes}
    sides = session.scalars(select(AxleReading.side).where(AxleReading.run_id == run_id))
    assert sorted(set(sides)) == ["arrival", "departure"]
    # A retry of the whole group is answered from the stored answers, unchanged.
    again = _group(session, items, executions)
    assert [o[1] for o in again] == [{**o[1], "status": "duplicate"} for o in outcomes]


def _answer_updates(executions: list[str]) -> int:
    return sum(text.startswith("UPDATE raw_events SET result") for text in executions)


def test_counts_whose_answer_is_foreseen_are_answered_in_their_insert(
    client: TestClient, session: Session, executions: list[str]
) -> None:
    """No run holds the section: every count's answer is known before it is stored, and goes
    in with its raw row (no second write of the answer)."""
    build_line(client)
    outcomes = _group(session, _counts(session, "seen", 12), executions)
    assert [o[0] for o in outcomes] == [201] * 12
    assert _answer_updates(executions) == 0, Counter(executions)
    assert _stored_answers(session, "seen") == {o[1]["event_id"]: o[1] for o in outcomes}


def test_a_departure_in_the_same_group_overrules_the_foreseen_answer(
    client: TestClient, session: Session, executions: list[str]
) -> None:
    """The departure is derived before the arrival counter's counts (the group derives in
    section, then device order: A-ilk before B-ac) and opens the run they belong to: what was
    foreseen (no run) is wrong, and the answers given and stored are the derivation's."""
    build_line(client)
    interlocking = session.get_one(Device, "A-ilk")
    departure = event("dep-2", "train_departed", "2026-11-23T09:59:30Z", section="AB")
    departure["train"] = "4713"
    items = [(interlocking, service.validate_event(interlocking, departure), departure)]
    items += [item for item in _counts(session, "late", 12) if item[0].id == "B-ac"]
    outcomes = _group(session, items, executions)
    run_id = session.scalar(select(RawEvent.id).where(RawEvent.event_id == "dep-2"))
    counts = [o[1] for o in outcomes[1:]]
    assert {c["run"] for c in counts} == {run_id}, counts
    assert _stored_answers(session, "late") == {c["event_id"]: c for c in counts}
