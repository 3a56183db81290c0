"""A JetStream message that cannot be stored ``max_deliver`` times goes to the dead-letter
subject with the reason, and is acknowledged: never silently dropped, never retried forever."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import nats

from tests.reliability.relkit import depot_env
from tests.transports.tkit import NatsDevices, Process, RunNames, brokers, consumer, until

UNREACHABLE = "postgresql+psycopg://postgres@127.0.0.1:1/nowhere"  # nothing listens on port 1
MAX_DELIVER = 2


def _failing_consumer(names: RunNames, tmp_path: Path) -> Process:
    """A consumer whose database is unreachable: every delivery fails, quickly redelivered."""
    env = {
        **depot_env(UNREACHABLE, tmp_path),
        **names.env(),
        "DEPOT_NATS_MAX_DELIVER": str(MAX_DELIVER),
        "DEPOT_NATS_ACK_WAIT_S": "1",
    }
    return consumer(env, tmp_path, 0)


def _heartbeat(event_id: str) -> bytes:
    event = {"event_id": event_id, "occurred_at": "2026-11-23T06:00:00Z", "kind": "heartbeat"}
    return json.dumps(event).encode()


def _dead_letters(names: RunNames, devices: NatsDevices) -> tuple[list[Any], Any]:
    """Waits for the dead letter; the letters and the events consumer's state after it."""
    dead_stream = f"{names.nats_prefix.upper()}_DEAD"
    until(lambda: devices.stream_messages(dead_stream) > 0, within=60, what="a dead letter")
    letters = devices.dead_letters(dead_stream, f"{names.nats_prefix}.dead.*")
    stream = f"{names.nats_prefix.upper()}_EVENTS"
    return letters, devices.consumer_info(stream, "depot-ingest")


def test_undeliverable_message_goes_to_dead_letters_with_reason(tmp_path: Path) -> None:
    names = RunNames()
    with brokers(names) as (_, __, devices):
        worker = _failing_consumer(names, tmp_path)
        worker.start()
        try:
            payload = _heartbeat("dl-1")
            devices.publish_all([("A-cam-1", "some-key", payload)])
            letters, info = _dead_letters(names, devices)
        finally:
            worker.stop()
    (letter,) = letters
    assert letter.subject == f"{names.nats_prefix}.dead.A-cam-1"
    assert letter.data == payload  # as the device sent it, so an operator can send it again
    reason = letter.headers["Depot-Dead-Reason"]
    # At least MAX_DELIVER: on a loaded machine a delivery can also expire (ack_wait 1 s) while
    # the consumer still tries the database, and JetStream counts it (CI saw "failed 4").
    failed = re.search(r"failed (\d+) deliveries", reason)
    assert failed is not None and int(failed.group(1)) >= MAX_DELIVER, reason
    assert "database unavailable" in reason, reason
    assert (info.num_ack_pending, info.num_pending) == (0, 0), "the dead letter was not acked"


def _lose_deliveries(devices: NatsDevices, stream: str, count: int, ack_wait_s: float) -> None:
    """Take ``count`` deliveries from the shared durable and never answer them, as a consumer
    killed while holding its batch (or a fetch that expired as the message arrived) does."""

    async def lose() -> None:
        sub: Any = await devices.nc.jetstream().pull_subscribe_bind("depot-ingest", stream=stream)
        lost = 0
        while lost < count:
            try:
                lost += len(await sub.fetch(1, timeout=ack_wait_s * 3))
            except nats.errors.TimeoutError:
                continue
        await sub.unsubscribe()

    devices.call(lose(), timeout=60)


def test_deliveries_lost_elsewhere_never_leave_a_message_stuck(tmp_path: Path) -> None:
    """JetStream counts a delivery whether or not a consumer saw it. If the server's own bound
    stopped redelivery, a message whose deliveries were lost would sit unacked for ever, in no
    dead letter: the consumer itself bounds deliveries and dead-letters what exceeds them."""
    names = RunNames()
    with brokers(names) as (_, __, devices):
        worker = _failing_consumer(names, tmp_path)
        worker.start()  # creates the stream and the durable consumer
        worker.stop()
        payload = _heartbeat("dl-2")
        devices.publish_all([("A-cam-1", "some-key", payload)])
        _lose_deliveries(devices, f"{names.nats_prefix.upper()}_EVENTS", MAX_DELIVER + 1, 1.0)
        worker.start()
        try:
            letters, info = _dead_letters(names, devices)
        finally:
            worker.stop()
    (letter,) = letters
    assert letter.data == payload
    assert "not acknowledged in time" in letter.headers["Depot-Dead-Reason"]
    assert (info.num_ack_pending, info.num_pending) == (0, 0), "the dead letter was not acked"
