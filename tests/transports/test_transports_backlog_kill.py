"""Kills that land mid-stream by construction, never by luck.

A backlog is waiting in the broker before the bridge (or a single consumer) starts; the
process is SIGKILLed as soon as the database shows the first of its rows committed, so most
of the backlog is still unstored (delivered and unacknowledged, or not yet delivered) at the
kill. After a restart every event is stored exactly once and answered "created" at most once.
The in-flight count at the kill is measured from the database and asserted > 0: while the
brokers are up these tests never skip.

Each device's backlog events share one ``occurred_at``, so the order in which two consumers
store them cannot change the derived liveness: the package's last test compares the live
state, these events included, with ``depot replay``.
"""

from __future__ import annotations

import json
import os
import signal
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import pytest
from sqlalchemy import create_engine, text

from tests.reliability.conftest import report
from tests.transports.conftest import Line
from tests.transports.tkit import Key, Process, forget_session, until

# MQTT: under Mosquitto's stock max_queued_messages (1000) for the bridge's offline session.
BACKLOG = {"mqtt": 800, "nats": 1500, "mqttw": 800}
KILL_AFTER_ROWS = 1  # the first commit of the restarted process
WITHIN_S = 120.0
OCCURRED_AT = {
    "mqtt": "2026-11-23T04:00:00Z",
    "nats": "2026-11-23T04:30:00Z",
    "mqttw": "2026-11-23T05:00:00Z",
}


def backlog_prefix(transport: str) -> str:
    return f"backlog-{transport}-"


class Rows:
    """Counts this backlog's stored rows, on one connection polled every few ms."""

    def __init__(self, line: Line, transport: str) -> None:
        self.engine = create_engine(line.database_url)
        self.connection = self.engine.connect()
        self.pattern = f"{backlog_prefix(transport)}%"

    def counts(self) -> tuple[int, int]:
        """(rows, distinct (device, event_id)) of the backlog, committed so far."""
        row = self.connection.execute(
            text(
                "SELECT count(*), count(DISTINCT (device_id, event_id)) FROM raw_events"
                " WHERE event_id LIKE :p"
            ),
            {"p": self.pattern},
        ).one()
        self.connection.commit()  # the next count sees what committed since
        return int(row[0]), int(row[1])

    def close(self) -> None:
        self.connection.close()
        self.engine.dispose()


def _messages(line: Line, transport: str) -> list[tuple[str, str | None, bytes]]:
    senders = [d for d in line.devices if d.kind != "camera"]
    out: list[tuple[str, str | None, bytes]] = []
    for n in range(BACKLOG[transport]):
        device = senders[n % len(senders)]
        event = {"event_id": f"{backlog_prefix(transport)}{n}", "kind": "heartbeat",
                 "occurred_at": OCCURRED_AT[transport]}  # fmt: skip
        out.append((device.id, device.key, json.dumps(event).encode()))
    return out


def _kill_at_first_commit(process: Process, rows: Rows) -> int:
    """Start ``process`` on the waiting backlog and SIGKILL it once a row is committed;
    returns the rows stored at the kill."""
    process.launch()
    deadline = time.monotonic() + WITHIN_S
    while rows.counts()[0] < KILL_AFTER_ROWS:
        assert time.monotonic() < deadline, f"nothing stored in {WITHIN_S} s"
        assert process.process is not None and process.process.poll() is None, "it exited"
        time.sleep(0.005)
    process.kill()
    return rows.counts()[0]


def _settle(
    request: pytest.FixtureRequest,
    line: Line,
    transport: str,
    messages: list[tuple[str, str | None, bytes]],
    at_kill: dict[str, int],
    rows: Rows,
) -> None:
    """Wait for every answer, then count lost, doubled and twice-created events."""
    keys: set[Key] = {(d, json.loads(p)["event_id"]) for d, _, p in messages}
    missing = line.answers.wait_for(keys, within=WITHIN_S)
    stored, distinct = rows.counts()
    created = Counter(k for k in keys for s in line.answers.by_key[k] if s == 201)
    figures = {
        **at_kill,
        "lost": len(keys) - distinct,
        "duplicated": stored - distinct + sum(n > 1 for n in created.values()),
        "answered_200_replay": sum(s == 200 for k in keys for s in line.answers.by_key[k]),
    }
    report(request, f"{transport} backlog kill", figures)
    assert not missing, f"{len(missing)} of {len(keys)} never answered, e.g. {list(missing)[:3]}"
    assert at_kill["in_flight_at_kill"] > 0, f"the kill found nothing in flight: {figures}"
    assert (figures["lost"], figures["duplicated"]) == (0, 0), figures
    refused = {k: s for k in keys for s in line.answers.by_key[k] if s not in (200, 201)}
    assert not refused, f"refused: {list(refused.items())[:3]}"


def _with_rows(line: Line, transport: str, body: Callable[[Rows], None]) -> None:
    rows = Rows(line, transport)
    try:
        assert rows.counts() == (0, 0), "the backlog's event ids were used before"
        body(rows)
    finally:
        rows.close()


def test_bridge_killed_mid_backlog_loses_and_doubles_nothing(
    request: pytest.FixtureRequest, line: Line
) -> None:
    messages = _messages(line, "mqtt")

    def run(rows: Rows) -> None:
        line.bridge.stop()  # the broker keeps what devices publish in the bridge's session
        for info in [line.mqtt.publish(*m) for m in messages]:
            info.wait_for_publish(30)  # PUBACKed: the broker holds it for the bridge
        stored = _kill_at_first_commit(line.bridge, rows)
        at_kill = {"stored_at_kill": stored, "in_flight_at_kill": len(messages) - stored}
        line.bridge.start()  # resumes its session: the unacknowledged messages come again
        _settle(request, line, "mqtt", messages, at_kill, rows)

    _with_rows(line, "mqtt", run)


def test_consumer_killed_mid_backlog_loses_and_doubles_nothing(
    request: pytest.FixtureRequest, line: Line
) -> None:
    messages = _messages(line, "nats")
    stream = f"{line.names.nats_prefix.upper()}_EVENTS"

    def run(rows: Rows) -> None:
        for process in line.consumers:
            process.stop()
        line.nats.publish_all(messages)  # stream-acked: JetStream holds all of them
        stored = _kill_at_first_commit(line.consumers[0], rows)
        info = line.nats.consumer_info(stream, "depot-ingest")
        at_kill = {
            "stored_at_kill": stored,
            "in_flight_at_kill": len(messages) - stored,
            "delivered_unacked_at_kill": int(info.num_ack_pending),
        }
        for process in line.consumers:  # the unacknowledged come again after ack_wait
            process.start()
        _settle(request, line, "nats", messages, at_kill, rows)

    _with_rows(line, "nats", run)


def _children(process: Process) -> list[int]:
    """The worker processes ``depot mqtt --workers N`` started (Linux /proc)."""
    assert process.process is not None
    pid = process.process.pid
    with open(f"/proc/{pid}/task/{pid}/children") as f:
        return [int(child) for child in f.read().split()]


def test_a_bridge_worker_killed_mid_backlog_loses_and_doubles_nothing(
    request: pytest.FixtureRequest, line: Line, tmp_path: Path
) -> None:
    """``depot mqtt --workers 2``: one worker SIGKILLed at the first commit; its supervisor
    starts it again under the same client id, it resumes its session and gets back what it
    had not acknowledged. (The line's own bridge shares the subscription and takes its part
    when it comes back.)"""
    messages = _messages(line, "mqttw")
    client_id = f"{line.names.client_id}-w"
    env = {**line.env, "DEPOT_MQTT_CLIENT_ID": client_id}
    workers = Process(env, tmp_path / "mqtt-workers.log", "mqtt", "--workers", "2",
                      ready="subscribed to")  # fmt: skip

    def run(rows: Rows) -> None:
        line.bridge.stop()
        workers.start()  # the workers' sessions subscribe, then wait offline for the backlog
        until(lambda: workers.log_text().count("subscribed to") >= 2, within=60,
              what="both workers subscribed")  # fmt: skip
        workers.stop()
        for info in [line.mqtt.publish(*m) for m in messages]:
            info.wait_for_publish(30)
        workers.launch()
        deadline = time.monotonic() + WITHIN_S
        while rows.counts()[0] < KILL_AFTER_ROWS or len(_children(workers)) < 2:
            assert time.monotonic() < deadline, f"nothing stored in {WITHIN_S} s"
            time.sleep(0.005)
        victim = _children(workers)[0]
        os.kill(victim, signal.SIGKILL)
        stored = rows.counts()[0]
        at_kill = {"stored_at_kill": stored, "in_flight_at_kill": len(messages) - stored}
        until(lambda: victim not in _children(workers) and len(_children(workers)) == 2,
              within=60, what="the killed worker started again")  # fmt: skip
        line.bridge.start()  # takes the part the broker gave the line's own session
        _settle(request, line, "mqttw", messages, at_kill, rows)

    try:
        _with_rows(line, "mqttw", run)
    finally:
        workers.stop()
        if line.bridge.process is None or line.bridge.process.poll() is not None:
            line.bridge.start()  # the package's later tests need the line's bridge
        for k in (1, 2):
            forget_session(f"{client_id}-{k}")
