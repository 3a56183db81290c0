"""A backlog in a broker does not make a silent device look alive later than it spoke.

JetStream: the events' receive time is when the stream stored the message, not when a
consumer got to it. The consumer of this test's own stream is down while the device
publishes; it starts a while later. The stored ``received_at`` (which liveness counts from)
is the stream's time: no later than the publisher had the stream's acknowledgement.

MQTT carries no broker time: the bridge is down while the device (its clock right) publishes,
and restarted a while later; the receive time is the bridge's read bounded by the event's own
``occurred_at``, so again no later than the broker's PUBACK to the device.
"""

from __future__ import annotations

import json
import time
from datetime import UTC, datetime
from pathlib import Path

from sqlalchemy import create_engine, text

from tests.transports.conftest import Line
from tests.transports.tkit import NATS_URL, Answers, NatsDevices, consumer
from transports.jetstream import ConsumeConfig, StreamNames, ensure_streams

SENDER = "T1-obu"
BACKLOG_S = 1.5  # how long the message waits in the stream before a consumer runs


def _received_at(line: Line, event_id: str) -> datetime:
    engine = create_engine(line.database_url)
    with engine.connect() as connection:
        value = connection.execute(
            text("SELECT received_at FROM raw_events WHERE device_id = :d AND event_id = :e"),
            {"d": SENDER, "e": event_id},
        ).scalar_one()
    engine.dispose()
    return value if isinstance(value, datetime) else datetime.fromisoformat(value)


def test_a_backlog_in_jetstream_keeps_the_time_the_stream_stored_it(
    line: Line, tmp_path: Path
) -> None:
    prefix = f"{line.names.nats_prefix}late"
    key = next(d.key for d in line.devices if d.id == SENDER)
    answers = Answers()
    devices = NatsDevices(prefix, answers)
    late = consumer({**line.env, "DEPOT_NATS_PREFIX": prefix}, tmp_path, 0)
    names = StreamNames(prefix)
    config = ConsumeConfig(NATS_URL, names, 1, 30.0, 10, 10, 4096)
    try:
        devices.call(ensure_streams(devices.nc.jetstream(), config))
        body = {"event_id": "late-1", "kind": "heartbeat", "occurred_at": "2026-11-23T03:00:00Z"}
        before = datetime.now(UTC)
        devices.publish_all([(SENDER, key, json.dumps(body).encode())])
        stored_by = datetime.now(UTC)  # the stream acknowledged: it stored the message by now
        time.sleep(BACKLOG_S)  # nobody consumes: the message waits in the stream
        late.start()
        assert not answers.wait_for({(SENDER, "late-1")}, within=60), "no answer came"
        assert answers.by_key[(SENDER, "late-1")] == [201]
        received = _received_at(line, "late-1").astimezone(UTC)
        assert before <= received <= stored_by, (
            f"received_at {received.isoformat()} is not the stream's time "
            f"(published between {before.isoformat()} and {stored_by.isoformat()})"
        )
    finally:
        late.stop()
        devices.delete_streams(prefix)
        devices.close()


def test_a_backlog_in_mosquitto_read_after_a_restart_keeps_the_time_the_device_spoke(
    line: Line,
) -> None:
    key = next(d.key for d in line.devices if d.id == SENDER)
    line.bridge.stop()
    try:
        before = datetime.now(UTC)
        body = {"event_id": "late-mqtt-1", "kind": "heartbeat",
                "occurred_at": before.isoformat().replace("+00:00", "Z")}  # fmt: skip
        line.mqtt.publish(SENDER, key, json.dumps(body).encode()).wait_for_publish(10)
        stored_by = datetime.now(UTC)  # PUBACKed: the broker holds it for the bridge's session
        time.sleep(BACKLOG_S)  # no bridge: the message waits in the session
    finally:
        line.bridge.start()
    assert not line.answers.wait_for({(SENDER, "late-mqtt-1")}, within=60), "no answer came"
    assert line.answers.by_key[(SENDER, "late-mqtt-1")] == [201]
    received = _received_at(line, "late-mqtt-1").astimezone(UTC)
    assert before <= received <= stored_by, (
        f"received_at {received.isoformat()} is the bridge's late read, not when the device "
        f"spoke (published between {before.isoformat()} and {stored_by.isoformat()})"
    )
