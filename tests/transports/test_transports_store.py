"""The broker batch's storage on each backend (SQLite and PostgreSQL), without brokers: several
devices' events in one transaction with one raw insert, each answered by itself, repeats as
the original, the transport's receive time kept (a backlog does not make a device alive)."""

from __future__ import annotations

import json
import uuid
from datetime import UTC, datetime, timedelta
from typing import Any

from sqlalchemy import Engine, event, select
from sqlalchemy.orm import Session, sessionmaker

from core.auth import device_cache
from core.models import Device
from ingest.models import RawEvent
from service import features
from tests.transports.tkit import register_devices
from transports.envelope import Message, handle_batch


def _heartbeat(event_id: str, occurred_at: str = "2026-11-23T03:00:00Z") -> bytes:
    return json.dumps(
        {"event_id": event_id, "kind": "heartbeat", "occurred_at": occurred_at}
    ).encode()


def test_a_batch_of_several_devices_is_stored_once_with_its_receive_times(
    engine: Engine, committed: sessionmaker[Session]
) -> None:
    features.install()
    sessions = committed
    tag = uuid.uuid4().hex[:8]
    keys = {f"st-{tag}-{n}": f"key-{tag}-{n}" for n in range(2)}
    register_devices(sessions, f"S{tag}", keys)
    one, two = list(keys)
    waited = datetime.now(UTC) - timedelta(minutes=3)  # when the broker got the first one
    batch = [
        Message(one, keys[one], _heartbeat(f"st-{tag}-1"), received_at=waited),
        Message(two, keys[two], _heartbeat(f"st-{tag}-2")),
        Message(one, keys[one], _heartbeat(f"st-{tag}-1"), received_at=waited),  # redelivered
        Message(one, keys[one], _heartbeat(f"st-{tag}-1", "2026-11-23T03:00:09Z")),  # reused id
        Message(two, keys[one], _heartbeat(f"st-{tag}-3")),  # another device's key
        Message(
            one, keys[one], json.dumps({"events": [json.loads(_heartbeat(f"st-{tag}-4"))]}).encode()
        ),
    ]
    before = datetime.now(UTC)
    answers = handle_batch(sessions, batch, transport="mqtt", max_bytes=4096)
    assert [a.status for a in answers] == [201, 201, 200, 409, 401, 200]
    assert answers[2].body["status"] == "duplicate"
    assert answers[5].body["results"][0]["status"] == "created"
    with Session(engine) as session:
        rows = session.scalars(select(RawEvent).where(RawEvent.device_id.in_(keys))).all()
    stored = {r.event_id: r for r in rows}
    assert sorted(stored) == [f"st-{tag}-1", f"st-{tag}-2", f"st-{tag}-4"]
    assert {r.transport for r in rows} == {"mqtt"}

    def utc(value: datetime) -> datetime:
        return value.replace(tzinfo=UTC) if value.tzinfo is None else value

    assert abs(utc(stored[f"st-{tag}-1"].received_at) - waited) < timedelta(milliseconds=1)
    assert utc(stored[f"st-{tag}-2"].received_at) >= before - timedelta(milliseconds=1)
    with Session(engine) as session:
        seen = session.get_one(Device, one).last_seen_at
    assert seen is not None and utc(seen) >= before - timedelta(milliseconds=1)  # -4 is now


def test_the_keys_a_batch_looked_up_are_cached_for_the_next(
    engine: Engine, committed: sessionmaker[Session]
) -> None:
    """A batch looks its devices' keys up with one query and keeps them in the key cache
    shared with HTTP (bounded by ``DEPOT_DEVICE_KEY_TTL_S``): the next batch asks the database
    for none of them (a bridge carrying 40 devices spent a fifth of its storing time on it)."""
    features.install()
    tag = uuid.uuid4().hex[:8]
    keys = {f"kc-{tag}-{n}": f"key-{tag}-{n}" for n in range(3)}
    register_devices(committed, f"K{tag}", keys)
    first = [Message(d, k, _heartbeat(f"{d}-1")) for d, k in keys.items()]
    assert [a.status for a in handle_batch(committed, first, transport="mqtt", max_bytes=4096)] == [
        201
    ] * 3
    assert {d: getattr(device_cache().peek(k), "id", None) for d, k in keys.items()} == {
        d: d for d in keys
    }
    asked: list[str] = []

    def record(_c: Any, _cur: Any, statement: str, *_: Any) -> None:
        if "key_hash" in statement:
            asked.append(statement)

    event.listen(engine, "before_cursor_execute", record)
    try:
        again = [Message(d, k, _heartbeat(f"{d}-2")) for d, k in keys.items()]
        answers = handle_batch(committed, again, transport="mqtt", max_bytes=4096)
    finally:
        event.remove(engine, "before_cursor_execute", record)
    assert [a.status for a in answers] == [201] * 3
    assert asked == [], "the second batch looked its keys up again"
