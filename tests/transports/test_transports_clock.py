"""Liveness over MQTT, whose messages carry no broker time: an event counts as received at the
bridge's read time bounded by its own occurred_at, so a backlog read late does not make a
silent device look alive, and a device's wrong clock can only make it look silent, never
alive (in-process, on SQLite and PostgreSQL, without brokers)."""

from __future__ import annotations

import json
import uuid
from datetime import UTC, datetime, timedelta

from sqlalchemy import Engine, select
from sqlalchemy.orm import Session, sessionmaker

from core.models import Device
from ingest.liveness import heartbeat_limit, is_stale, silent_at
from ingest.models import RawEvent
from service import features
from tests.transports.tkit import register_devices
from transports.envelope import Message, handle_batch

FAR_PAST = datetime(2001, 1, 1, 6, 0, tzinfo=UTC)
FUTURE = datetime(2030, 1, 1, 6, 0, tzinfo=UTC)


def _utc(value: datetime | None) -> datetime | None:
    if value is None:
        return None
    return value.replace(tzinfo=UTC) if value.tzinfo is None else value


def _heartbeat(event_id: str, at: datetime) -> bytes:
    when = at.isoformat().replace("+00:00", "Z")
    return json.dumps({"event_id": event_id, "kind": "heartbeat", "occurred_at": when}).encode()


def _devices(sessions: sessionmaker[Session], names: list[str]) -> dict[str, tuple[str, str]]:
    """A registered device per case: (device id, key) by case name."""
    tag = uuid.uuid4().hex[:8]
    made = {name: (f"clk-{tag}-{name}", f"key-{tag}-{name}") for name in names}
    register_devices(sessions, f"C{tag}", dict(made.values()))
    return made


def test_read_times_are_bounded_by_the_events_own_time(
    engine: Engine, committed: sessionmaker[Session]
) -> None:
    features.install()
    read = datetime.now(UTC)  # when the bridge read every message of this batch
    spoke = {
        "backlog": read - 10 * heartbeat_limit(),  # went silent then; read after a restart
        "ahead": read + timedelta(seconds=120),  # a clock ahead, within the allowed skew
        "far-past": FAR_PAST,  # a clock set back
        "2030": FUTURE,  # refused: beyond the skew
        "live": read - timedelta(milliseconds=50),  # read as it came
    }
    devices = _devices(committed, list(spoke))
    batch = [
        Message(device_id, key, _heartbeat(f"{device_id}-1", spoke[name]), read, True)
        for name, (device_id, key) in devices.items()
    ]
    answers = handle_batch(committed, batch, transport="mqtt", max_bytes=4096)
    assert [a.status for a in answers] == [201, 201, 201, 422, 201], [a.body for a in answers]
    expected = {
        "backlog": spoke["backlog"],  # its own time, not the late read
        "ahead": read,  # never later than the read: the clock cannot keep it alive
        "far-past": FAR_PAST,
        "live": spoke["live"],
    }
    later = read + timedelta(seconds=1)
    with Session(committed.kw["bind"]) as session:
        for name, (device_id, _) in devices.items():
            row = session.scalar(select(RawEvent).where(RawEvent.device_id == device_id))
            device = session.get_one(Device, device_id)
            if name == "2030":
                assert row is None and device.last_seen_at is None
            else:
                assert row is not None
                assert abs(_utc(row.received_at) - expected[name]) < timedelta(milliseconds=1)
            alive = name in ("ahead", "live")  # spoke within the heartbeat before `later`
            assert is_stale(device, later) is not alive, (name, device.last_seen_at)
            assert silent_at(session, device, later) is not alive, name


def test_without_a_read_time_flag_the_transports_time_is_kept(
    engine: Engine, committed: sessionmaker[Session]
) -> None:
    """JetStream's time is the stream's own (when it stored the message): kept as it is, even
    when the device's clock says the event is older."""
    features.install()
    stored = datetime.now(UTC) - timedelta(seconds=30)
    ((device_id, key),) = _devices(committed, ["stream"]).values()
    message = Message(device_id, key, _heartbeat(f"{device_id}-1", FAR_PAST), stored)
    assert handle_batch(committed, [message], transport="nats", max_bytes=4096)[0].status == 201
    with Session(committed.kw["bind"]) as session:
        row = session.scalar(select(RawEvent).where(RawEvent.device_id == device_id))
    assert row is not None and abs(_utc(row.received_at) - stored) < timedelta(milliseconds=1)
