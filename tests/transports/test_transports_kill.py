"""Kills under load: two ``depot serve``, one ``depot mqtt`` and two ``depot consume`` share one
PostgreSQL database while the 50 devices of the line send trains round after round, a third of
them over each transport (cameras always over HTTP: snapshots are multipart uploads). Like
real devices, each sends its events in order: one after the other over HTTP and MQTT, and
over JetStream as one ``{"events": [...]}`` message per phase (two consumers may take a
device's messages at the same time, and the service's liveness clock is not commutative).

* the bridge is SIGKILLed while MQTT messages are in flight, and restarted;
* the bridge is down while devices publish a whole phase, and started afterwards;
* a consumer is SIGKILLed while JetStream messages are in flight; the other one finishes.

These kills come at a moment of the phase, so they may find little or nothing in flight (the
counts are reported); the kills that land mid-stream by construction are in
``test_transports_backlog_kill.py``, whose events are part of the replay comparison here.

Afterwards every event is stored exactly once with the transport it came by, each one was
answered "created" at most once (a redelivery after the commit is answered as a replay),
and the live derived state equals ``depot replay``'s.
"""

from __future__ import annotations

import json
import threading
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import httpx
import pytest
from sqlalchemy import create_engine, text

from tests.reliability.conftest import report
from tests.reliability.dbcheck import assert_derived_cleanly, derived_state, stored_events
from tests.reliability.loadgen import Device, Payloads, Stats, events_for, post_until_acked
from tests.reliability.relkit import run_depot
from tests.transports.conftest import Line
from tests.transports.tkit import Key, until

ROUNDS = 4  # kills in rounds 1, 2 and 3
PHASE_WITHIN_S = 90.0  # bound on one phase, kills and restarts included
EVIDENCE = 1  # the phase with the most events (readers, heartbeats)
OTHER_TESTS = (
    "bad-",
    "backlog-",
    "late-",
)  # event ids of the package's earlier tests, same database


def transport_of(index: int, device: Device) -> str:
    if device.kind == "camera":
        return "http"
    return ("mqtt", "nats", "http")[index % 3]


class Driver:
    """Sends each phase over the devices' transports and waits until all is answered."""

    def __init__(self, line: Line, payloads: Payloads) -> None:
        self.line, self.payloads = line, payloads
        self.http = Stats()
        self.sent: dict[Key, tuple[str, dict[str, Any]]] = {}
        self.pending_at_kill: dict[str, int] = {}
        self.clients = {
            d.id: httpx.Client(
                base_url=line.servers[n % 2].url, headers={"X-Device-Key": d.key}, timeout=30
            )
            for n, d in enumerate(line.devices)
        }
        self.pool = ThreadPoolExecutor(max_workers=8)

    def phase(self, r: int, phase: int, during: Callable[[set[Key]], None] | None) -> None:
        broker: dict[str, list[tuple[str, str | None, bytes]]] = {"mqtt": [], "nats": []}
        waiting: set[Key] = set()
        futures: list[Future[Any]] = []
        deadline = time.monotonic() + PHASE_WITHIN_S
        for index, device in enumerate(self.line.devices):
            transport = transport_of(index, device)
            postings = events_for(device, r, phase, self.payloads)
            for _, body in postings:
                self.sent[(device.id, str(body["event_id"]))] = (transport, body)
            if not postings:
                continue
            if transport == "http":  # a device posts one event after the other
                futures.append(self.pool.submit(self._post_in_turn, device, postings, deadline))
                continue
            waiting |= {(device.id, str(body["event_id"])) for _, body in postings}
            if transport == "mqtt":
                broker["mqtt"] += [(device.id, device.key, json.dumps(b).encode())
                                   for _, b in postings]  # fmt: skip
            else:  # one JetStream message per device and phase: its events in their order
                batch = {"events": [body for _, body in postings]}
                broker["nats"].append((device.id, device.key, json.dumps(batch).encode()))
        publishing: list[Future[Any]] = [
            self.pool.submit(lambda: [self.line.mqtt.publish(*m) for m in broker["mqtt"]]),
            self.pool.submit(self.line.nats.publish_all, broker["nats"]),
        ]
        if during is not None:
            during(waiting)
        for future in [*publishing, *futures]:
            future.result(timeout=PHASE_WITHIN_S)
        missing = self.line.answers.wait_for(waiting, within=PHASE_WITHIN_S)
        assert not missing, f"round {r} phase {phase}: {len(missing)} never answered"

    def _post_in_turn(self, device: Device, postings: list[Any], deadline: float) -> None:
        for posting in postings:
            post_until_acked(
                self.clients[device.id], self.http, device, posting, self.payloads, deadline
            )

    def close(self) -> None:
        self.pool.shutdown()
        for client in self.clients.values():
            client.close()


def _answered_share(line: Line, keys: set[Key], share: float) -> Callable[[], bool]:
    return lambda: sum(k in line.answers.by_key for k in keys) >= share * len(keys)


def _kill_bridge_mid_stream(line: Line, driver: Driver) -> Callable[[set[Key]], None]:
    def during(keys: set[Key]) -> None:
        mqtt_keys = {k for k in keys if driver.sent[k][0] == "mqtt"}
        until(_answered_share(line, mqtt_keys, 0.1), within=60, what="MQTT answers")
        line.bridge.kill()
        driver.pending_at_kill["bridge"] = sum(k not in line.answers.by_key for k in mqtt_keys)
        line.bridge.start()

    return during


def _kill_consumer_mid_stream(line: Line, driver: Driver) -> Callable[[set[Key]], None]:
    def during(keys: set[Key]) -> None:
        nats_keys = {k for k in keys if driver.sent[k][0] == "nats"}
        until(_answered_share(line, nats_keys, 0.1), within=60, what="JetStream answers")
        line.consumers[0].kill()  # not restarted: the other consumer finishes the work
        driver.pending_at_kill["consumer"] = sum(k not in line.answers.by_key for k in nats_keys)

    return during


def _check_stored(line: Line, driver: Driver) -> dict[str, int]:
    stored = stored_events(line.database_url)
    ours = {k: v for k, v in stored.items() if not k[1].startswith(OTHER_TESTS)}
    missing = [k for k in driver.sent if k not in ours]
    assert not missing, f"{len(missing)} events lost, e.g. {missing[:5]}"
    assert set(ours) == set(driver.sent), "stored events nobody sent"
    twice = [k for k, (n, _, _) in ours.items() if n != 1]
    assert not twice, f"stored more than once: {twice[:5]}"
    for key, (_, body, _) in ours.items():
        transport, sent = driver.sent[key]
        if "kind" in sent:  # events are stored as sent; snapshots as their metadata
            assert body == sent, f"{key} stored with another body"
    created = Counter(
        k for k, statuses in line.answers.by_key.items() for s in statuses if s == 201
    )
    by_broker = [k for k, (t, _) in driver.sent.items() if t != "http"]
    # A bridge killed after the commit but before its answer left answers the redelivery with
    # the replay (200): "created" at most once, never twice.
    wrong = {k: line.answers.by_key[k] for k in by_broker if created[k] > 1}
    assert not wrong, f"answered 'created' twice: {list(wrong.items())[:5]}"
    assert not any(s not in (200, 201) for k in by_broker for s in line.answers.by_key[k]), (
        "a broker event was refused"
    )
    return dict(Counter(t for t, _ in driver.sent.values()))


def _transports_recorded(line: Line, driver: Driver) -> None:
    engine = create_engine(line.database_url)
    with engine.connect() as connection:
        rows = connection.execute(text("SELECT device_id, event_id, transport FROM raw_events"))
        recorded = {(d, e): t for d, e, t in rows if not e.startswith(OTHER_TESTS)}
    engine.dispose()
    wrong = [k for k, t in recorded.items() if driver.sent[k][0] != t]
    assert not wrong, f"transport recorded wrongly for {wrong[:5]}"


def test_kills_lose_nothing_and_double_nothing(
    request: pytest.FixtureRequest, line: Line, payloads: Payloads
) -> None:
    driver = Driver(line, payloads)
    plan = {
        (1, EVIDENCE): _kill_bridge_mid_stream(line, driver),
        (2, EVIDENCE): _kill_consumer_mid_stream(line, driver),
    }
    try:
        for r in range(ROUNDS):
            for phase in range(3):
                if (r, phase) == (3, EVIDENCE):
                    _offline_phase(line, driver, r, phase)
                    continue
                driver.phase(r, phase, plan.get((r, phase)))
    finally:
        driver.close()
    counts = _check_stored(line, driver)
    _transports_recorded(line, driver)
    for process in (*line.consumers, line.bridge):
        process.stop()
    for server in line.servers:
        server.stop()
    live = derived_state(line.database_url)
    done = run_depot(line.env, "replay")
    assert done.returncode == 0, done.stdout + done.stderr
    rebuilt = derived_state(line.database_url)
    for table in live:
        assert rebuilt[table] == live[table], (
            f"{table}: live state differs from depot replay: "
            f"{[(a, b) for a, b in zip(live[table], rebuilt[table], strict=False) if a != b][:3]}"
            f"{_raw_rows(line, live[table], rebuilt[table])}"
        )
    assert_derived_cleanly(line.database_url)
    report(request, "transports kill test", {
        "events": counts, "pending_at_kill": driver.pending_at_kill,
        "replays_answered_200": sum(s == 200 for v in line.answers.by_key.values() for s in v),
        "http": driver.http.summary()["statuses"],
    })  # fmt: skip


def _raw_rows(line: Line, live: list[Any], rebuilt: list[Any]) -> str:
    """For a differing device: its stored events in id order (what replay follows)."""
    differing = [a[0] for a, b in zip(live, rebuilt, strict=False) if a != b]
    # Only a table keyed by device names a device (a run's or a reading's integer id does not:
    # compared with device_id, PostgreSQL refuses varchar = integer and hides the difference).
    if not differing or differing[0] not in {d.id for d in line.devices}:
        return ""
    engine = create_engine(line.database_url)
    with engine.connect() as connection:
        rows = connection.execute(
            text("SELECT id, kind, occurred_at, received_at, transport FROM raw_events "
                 "WHERE device_id = :d ORDER BY id DESC LIMIT 6"), {"d": differing[0]}
        ).all()  # fmt: skip
    engine.dispose()
    return f"; latest events of {differing[0]}: {[tuple(map(str, r)) for r in rows]}"


def _offline_phase(line: Line, driver: Driver, r: int, phase: int) -> None:
    """The bridge is down for the whole phase: the broker keeps the devices' messages."""
    line.bridge.kill()
    restart = threading.Timer(3.0, line.bridge.start)  # devices publish meanwhile
    restart.start()
    try:
        driver.phase(r, phase, None)
    finally:
        restart.join()
