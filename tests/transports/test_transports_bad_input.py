"""Every kind of bad message over MQTT and JetStream: answered with the HTTP status,
acknowledged (it does not come back), and nothing stored for it."""

from __future__ import annotations

import json
import time
from typing import Any

import httpx
import pytest
from sqlalchemy import create_engine, text

from tests.reliability.conftest import ADMIN_HEADERS
from tests.transports.conftest import MAX_BODY_BYTES, Line
from tests.transports.tkit import until

SENDER = "T1-obu"  # an on-board unit: may send heartbeats and motion samples, not departures


def _event(event_id: str, **fields: Any) -> dict[str, Any]:
    return {"event_id": event_id, "occurred_at": "2026-11-23T06:00:00Z", "kind": "heartbeat",
            **fields}  # fmt: skip


def _ask(line: Line, transport: str, key: str | None, payload: bytes) -> dict[str, Any]:
    """Send one message as ``SENDER`` and wait for the answer on its results topic."""
    before = len([b for d, b in line.answers.bodies if d == SENDER])
    if transport == "mqtt":
        line.mqtt.publish(SENDER, key, payload).wait_for_publish(10)
    else:
        line.nats.publish_all([(SENDER, key, payload)])
    until(
        lambda: len([b for d, b in line.answers.bodies if d == SENDER]) > before,
        within=30,
        what=f"an answer over {transport}",
    )
    return [b for d, b in line.answers.bodies if d == SENDER][before]


def _cases(line: Line, transport: str) -> list[tuple[str, str | None, bytes, int]]:
    """(what, key, payload, expected http_status), in the order they are sent."""
    key = next(d.key for d in line.devices if d.id == SENDER)
    other = next(d.key for d in line.devices if d.id == "T2-obu")
    ok = json.dumps(_event(f"bad-{transport}-ok")).encode()
    reused = json.dumps(_event(f"bad-{transport}-ok", occurred_at="2026-11-23T06:00:01Z"))
    departed = _event(f"bad-{transport}-dep", kind="train_departed", section="S0S1", train="1")
    return [
        ("new event", key, ok, 201),
        ("retry of it", key, ok, 200),
        ("same event_id, other body", key, reused.encode(), 409),
        ("another device's key", other, json.dumps(_event(f"bad-{transport}-k")).encode(), 401),
        ("no key", None, json.dumps(_event(f"bad-{transport}-nokey")).encode(), 401),
        ("not JSON", key, b"\x00{heartbeat", 422),
        ("unknown kind", key, json.dumps(_event(f"bad-{transport}-u", kind="tea")).encode(), 422),
        ("kind not allowed", key, json.dumps(departed).encode(), 403),
        ("invalid field", key,
         json.dumps(_event(f"bad-{transport}-f", occurred_at="soon")).encode(), 422),
        ("too large", key, b'{"pad": "' + b"x" * MAX_BODY_BYTES + b'"}', 413),
        ("batch", key, json.dumps({"events": [_event(f"bad-{transport}-b1"),
                                              _event(f"bad-{transport}-ok")]}).encode(), 200),
    ]  # fmt: skip


def _named(transport: str) -> dict[str, str]:
    """The event id each refusal must name (its payload is JSON with one), by case."""
    return {
        "same event_id, other body": f"bad-{transport}-ok",
        "another device's key": f"bad-{transport}-k",
        "no key": f"bad-{transport}-nokey",
        "unknown kind": f"bad-{transport}-u",
        "kind not allowed": f"bad-{transport}-dep",
        "invalid field": f"bad-{transport}-f",
    }


def _stored(line: Line, transport: str) -> dict[str, str]:
    engine = create_engine(line.database_url)
    try:
        with engine.connect() as connection:
            rows = connection.execute(
                text("SELECT event_id, transport FROM raw_events WHERE event_id LIKE :p"),
                {"p": f"bad-{transport}-%"},
            ).all()
    finally:
        engine.dispose()
    return {e: t for e, t in rows}


@pytest.mark.parametrize("transport", ["mqtt", "nats"])
def test_bad_messages_are_answered_acknowledged_and_not_stored(line: Line, transport: str) -> None:
    for what, key, payload, status in _cases(line, transport):
        answer = _ask(line, transport, key, payload)
        assert answer["http_status"] == status, f"{what}: {answer}"
        if status >= 400:
            assert answer["status"] == status and answer["detail"], f"{what}: {answer}"
            # the device matches the refusal to its message by these
            assert answer["device"] == SENDER, f"{what}: {answer}"
            assert answer.get("event_id") == _named(transport).get(what), f"{what}: {answer}"
    batch = answer["results"]
    assert [r["status"] for r in batch] == ["created", "duplicate"]
    # Only the two new events were stored, each marked with the transport it came by.
    assert _stored(line, transport) == {f"bad-{transport}-ok": transport,
                                        f"bad-{transport}-b1": transport}  # fmt: skip
    log = httpx.get(
        f"{line.servers[1].url}/api/v1/events",
        params={"device": SENDER, "limit": 2},
        headers=ADMIN_HEADERS,
    ).json()
    assert [i["event_id"] for i in log["items"]] == [f"bad-{transport}-b1", f"bad-{transport}-ok"]
    assert {i["transport"] for i in log["items"]} == {transport}
    _assert_acknowledged(line, transport)


def _assert_acknowledged(line: Line, transport: str) -> None:
    """Nothing of the above comes back: not after ack_wait, not to a restarted bridge."""
    answered = len(line.answers.bodies)
    if transport == "nats":
        stream = f"{line.names.nats_prefix.upper()}_EVENTS"
        time.sleep(3)  # longer than ack_wait: an unacknowledged message would be redelivered
        info = line.nats.consumer_info(stream, "depot-ingest")
        assert (info.num_ack_pending, info.num_pending, info.num_redelivered) == (0, 0, 0)
    else:
        line.bridge.stop()
        line.bridge.start()  # a resumed session gets the unacknowledged messages first
        marker = json.dumps(_event("bad-mqtt-marker")).encode()
        key = next(d.key for d in line.devices if d.id == SENDER)
        assert _ask(line, "mqtt", key, marker)["http_status"] == 201
    assert len(line.answers.bodies) == answered + (transport == "mqtt"), "a message came back"


def test_event_log_is_for_operators_and_pages_newest_first(line: Line) -> None:
    url = f"{line.servers[0].url}/api/v1/events"
    device_key = {"X-Device-Key": next(d.key for d in line.devices if d.id == SENDER)}
    for n in range(2):  # two events of its own, whatever ran before
        body = _event(f"bad-log-{n}", occurred_at=f"2026-11-23T06:00:0{n}Z")
        assert httpx.post(url, json=body, headers=device_key).status_code == 201
    assert httpx.get(url).status_code == 401
    assert httpx.get(url, headers=device_key).status_code == 403
    assert httpx.get(url, params={"limit": 1001}, headers=ADMIN_HEADERS).status_code == 422
    first = httpx.get(url, params={"device": SENDER, "limit": 1}, headers=ADMIN_HEADERS).json()
    second = httpx.get(
        url, params={"device": SENDER, "limit": 1, "before": first["next"]}, headers=ADMIN_HEADERS
    ).json()
    assert first["next"] is not None and len(first["items"]) == len(second["items"]) == 1
    newer, older = first["items"][0], second["items"][0]
    assert (newer["device"], older["device"]) == (SENDER, SENDER)
    assert newer["event_id"] != older["event_id"]
    assert newer["received_at"] >= older["received_at"] and newer["received_at"].endswith("Z")
