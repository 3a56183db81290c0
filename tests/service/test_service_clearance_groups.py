"""Axle counts derived as a group (one transaction: the HTTP group commit, a broker batch,
replay) reach exactly the state the same events reach one by one, with few SQL statements: the
section's runs are read once per group, the readings inserted together."""

from __future__ import annotations

import json
import random
import re
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime, timedelta
from typing import Any

import pytest
from sqlalchemy import delete, event, select
from sqlalchemy.orm import Session

from core.models import Device, Section
from ingest.checks import parse_event
from ingest.group import store_group
from ingest.models import RawEvent
from ingest.multi_store import DeviceBatch, accept_batches
from service.clearance.models import AxleReading, Run
from service.clearance.service import lock_section
from service.replay import replay, reset_derived
from tests.service.scenario import T0, Line, iso
from transports.envelope import Message, _grouped


@contextmanager
def counted(session: Session) -> Iterator[list[str]]:
    """Every SQL statement the session's connection sends while the block runs."""
    seen: list[str] = []
    engine = session.get_bind().engine

    def count(*args: Any) -> None:
        seen.append(str(args[2]).split()[0] + " " + " ".join(str(args[2]).split()[1:12]))

    event.listen(engine, "before_cursor_execute", count)
    try:
        yield seen
    finally:
        event.remove(engine, "before_cursor_execute", count)


def body(serial: int, kind: str, at: datetime, **fields: Any) -> dict[str, Any]:
    return {"event_id": f"g-{serial}", "occurred_at": iso(at), "kind": kind, **fields}


def as_group(session: Session, items: list[tuple[str, dict[str, Any]]]) -> list[Any]:
    group = [(session.get_one(Device, d), parse_event(b), b) for d, b in items]
    outcomes = store_group(session, group)
    session.commit()
    return outcomes


def _counts(serial: int, n: int, start: datetime) -> list[tuple[str, dict[str, Any]]]:
    return [
        (
            "A-ac" if i % 2 == 0 else "B-ac",
            body(serial + i, "axle_count", start + timedelta(seconds=i), section="AB", axles=16),
        )
        for i in range(n)
    ]


def test_a_group_of_axle_counts_costs_few_statements(line: Line, session: Session) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    line.depart(T0)
    items = _counts(0, 30, T0 + timedelta(seconds=5))
    with counted(session) as statements:
        as_group(session, items)
    derived = [s for s in statements if s not in ("BEGIN", "COMMIT", "SAVEPOINT", "RELEASE")]
    per_event = len(derived) / len(items)
    print(f"\n{len(derived)} statements for {len(items)} axle counts: {per_event:.2f} per event")
    assert session.scalar(select(AxleReading.run_id).limit(1)) is not None
    assert per_event <= 0.35, "\n".join(derived)


def test_a_broker_batch_of_axle_counts_costs_few_statements(line: Line, session: Session) -> None:
    """A broker batch (``handle_batch``'s first, all-together pass) derives without a savepoint
    per event, as the group commit does: each event's savepoint used to flush its reading
    alone, and its release forgot the section's lock, which was then taken and the runs read
    again for every event (5 statements per axle count; 462 events/s over MQTT)."""
    line.heartbeat_all(T0 - timedelta(seconds=20))
    run = line.depart(T0)
    messages = [
        Message(d, line.keys[d]["X-Device-Key"], json.dumps(b).encode())
        for d, b in _counts(1000, 60, T0 + timedelta(seconds=5))
    ]
    with counted(session) as statements:
        answers = _grouped(session, messages, "mqtt", 65536)
        session.commit()
    assert [a.status for a in answers] == [201] * len(messages)
    derived = [s for s in statements if s not in ("BEGIN", "COMMIT", "SAVEPOINT", "RELEASE")]
    # The test session's own transaction is a savepoint (one pair); none per event.
    assert len([s for s in statements if s.startswith(("SAVEPOINT", "RELEASE"))]) <= 2
    assert len(derived) / len(messages) <= 0.2, "\n".join(derived)
    attached = session.scalars(select(AxleReading.run_id).where(AxleReading.run_id.is_not(None)))
    assert set(attached) == {run}


def test_a_section_lock_outlives_a_savepoint_but_not_its_transaction(
    line: Line, session: Session
) -> None:
    """Locked once per transaction: the release of a savepoint keeps the lock (and what was
    read under it); a rollback to a savepoint, and the end of the transaction, forget it, so
    the next transaction locks the row again instead of trusting a lock it no longer holds."""

    def section_reads(statements: list[str]) -> int:
        return sum(1 for s in statements if s.startswith("SELECT") and "sections" in s)

    held = []  # kept referenced, so that a look-up of the locked row is answered in memory
    with counted(session) as statements:
        held.append(lock_section(session, "AB"))
        with session.begin_nested():
            held.append(lock_section(session, "AB"))
        held.append(lock_section(session, "AB"))
    assert section_reads(statements) == 1, statements
    session.commit()
    with counted(session) as statements:
        held.append(lock_section(session, "AB"))
    assert section_reads(statements) == 1, statements
    with counted(session) as statements:
        savepoint = session.begin_nested()
        held.append(lock_section(session, "AB"))
        savepoint.rollback()
        held.append(lock_section(session, "AB"))
    assert section_reads(statements) == 1, statements
    session.rollback()
    with counted(session) as statements:
        held.append(lock_section(session, "AB"))
    assert section_reads(statements) == 1, statements


def _sequence(seed: int) -> list[tuple[str, str, datetime, dict[str, Any]]]:
    """A random stretch of traffic in AB: two or three trains (some in conflict, some
    arrivals or departures missing), axle counts at both ends, in a random order."""
    rng = random.Random(seed)
    events: list[tuple[str, str, datetime, dict[str, Any]]] = []
    start = T0
    for number in range(rng.randint(2, 3)):
        train = f"20{41 + 2 * number}"
        transit = timedelta(minutes=rng.randint(5, 20))
        if rng.random() > 0.1:
            events.append(("A-ilk", "train_departed", start, {"train": train}))
        if rng.random() > 0.2:
            events.append(("B-ilk", "train_arrived", start + transit, {"train": train}))
        for _ in range(rng.randint(2, 6)):
            end = rng.choice(["A-ac", "B-ac"])
            at = start + timedelta(seconds=rng.randint(-120, int(transit.total_seconds()) + 120))
            events.append((end, "axle_count", at, {"axles": rng.choice([16, 16, 16, 12, 20])}))
        start += timedelta(minutes=rng.randint(2, 30))
    rng.shuffle(events)
    return events


def state(session: Session) -> dict[str, Any]:
    """Runs, readings and the section, by what they are (not by raw ids, which differ)."""
    session.expire_all()
    runs = {r.id: r for r in session.scalars(select(Run))}

    def name(run_id: int | None) -> Any:
        run = runs.get(run_id) if run_id is not None else None
        return None if run is None else (run.train, run.departed_at)

    def words(reasons: list[str]) -> tuple[str, ...]:
        named = {str(i): f"<{r.train}>" for i, r in runs.items()}
        return tuple(re.sub(r"run (\d+)", lambda m: "run " + named[m[1]], w) for w in reasons)

    section = session.get_one(Section, "AB")
    return {
        "runs": sorted(
            (
                r.train,
                r.departed_at,
                r.arrived_at,
                r.status,
                r.verdict,
                words(r.reasons),
                r.arrival_train,
                r.conflict is not None,
            )
            for r in runs.values()
        ),
        "readings": sorted(
            (r.device_id, r.occurred_at, r.axles, name(r.run_id), r.side)
            for r in session.scalars(select(AxleReading))
        ),
        "section": (section.state, name(section.current_run_id)),
    }


def _forget_events(session: Session) -> None:
    reset_derived(session)
    session.execute(delete(RawEvent).where(RawEvent.kind != "heartbeat"))
    session.commit()


def as_broker_batch(session: Session, items: list[tuple[str, dict[str, Any]]]) -> None:
    """One broker batch; each item its own device batch, derived in the order given."""
    batches = [DeviceBatch(session.get_one(Device, d), [b]) for d, b in items]
    accept_batches(session, batches, transport="mqtt")
    session.commit()


@pytest.mark.parametrize("path", ["group_commit", "broker"])
@pytest.mark.parametrize("seed", range(6))
def test_a_group_reaches_the_state_of_one_by_one(
    line: Line, session: Session, seed: int, path: str
) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    events = _sequence(seed)
    if path == "group_commit":  # the group commit derives in lock order: section, device
        events.sort(key=lambda e: e[0])
    for device, kind, at, fields in events:
        line.post(device, kind, at, section="AB", **fields)
    one_by_one = state(session)
    replay(session)
    session.commit()
    assert state(session) == one_by_one, "replay"
    _forget_events(session)
    line.heartbeat_all(T0 - timedelta(seconds=20))
    items = [
        (d, body(1000 + i, k, at, section="AB", **f)) for i, (d, k, at, f) in enumerate(events)
    ]
    (as_group if path == "group_commit" else as_broker_batch)(session, items)
    assert state(session) == one_by_one, path
    replay(session)
    session.commit()
    assert state(session) == one_by_one, f"replay after {path}"
