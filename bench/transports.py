"""Events per second into PostgreSQL over HTTP, MQTT (``depot mqtt``) and JetStream
(``depot consume``), side by side in one run on one database.

Each transport carries the same single-event messages (axle counts and heartbeats from 40
devices) and is timed from the first send to the last answer: over HTTP the 201 of the last
POST, over the brokers the last answer on the results topic, which the service publishes only
after the commit that stored the event (the broker is acknowledged after that commit too).

    .venv/bin/python -m bench.transports [--events 4000] [--mqtt-workers 2]

The bench database is named after the one ``DEPOT_TEST_POSTGRES_URL`` names (``X`` →
``X_bench_transports``), so benches of two worktrees on one server never drop each other's.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import httpx

from bench._server import ADMIN_TOKEN, admin, bench_database, serve
from transports.mqtt import MqttConfig
from transports.mqtt_workers import worker_configs

DEPOT = str(Path(sys.executable).parent / "depot")
DEVICES = 40
HTTP_CLIENTS = 8
# The bridge's batch and its MQTT 5 receive maximum: twice the batch, so that the broker sends
# the next batch while the bridge commits the one in hand (with receive maximum == batch the
# two alternate). Set here so that the figures say what they were measured with.
BATCH, INFLIGHT = 500, 1000
# Messages sent and not yet answered, at most. Mosquitto queues at most max_queued_messages
# (default 1000) for a subscriber beyond its in-flight window and drops the rest, although the
# devices already got their PUBACK; deploy/mosquitto.conf raises the limit, this broker is stock.
MQTT_WINDOW = INFLIGHT + 500
# depot mqtt --workers: bridge processes on the shared subscription (one interpreter bounds one).
MQTT_WORKERS = 2


def _devices(url: str) -> list[tuple[str, str]]:
    """A station pair, one section, 40 axle counters: (id, key)."""
    with httpx.Client(base_url=f"{url}/api/v1", headers=admin(), timeout=30) as client:
        for station in ("A", "B"):
            client.post("/stations", json={"id": station, "name": station}).raise_for_status()
        section = {"id": "AB", "from_station": "A", "to_station": "B", "mode": "primary"}
        client.post("/sections", json=section).raise_for_status()
        out = []
        for n in range(DEVICES):
            body = {"id": f"AB-ac-{n}", "station": "A", "section": "AB", "kind": "axle_counter"}
            response = client.post("/devices", json=body)
            response.raise_for_status()
            out.append((body["id"], response.json()["key"]))
    return out


def _events(
    tag: str, count: int, devices: list[tuple[str, str]], mix: str
) -> list[tuple[str, str, bytes]]:
    """``count`` messages spread over the devices: heartbeats only (``mix="heartbeat"``), or
    axle counts with every fifth a heartbeat (``"mixed"``)."""
    # Dated now, as devices with a right clock date them: over MQTT the event's own time
    # bounds its receive time (liveness), so a date long past would spare the bench the
    # liveness writes a real device costs.
    now = datetime.now(UTC)
    out = []
    for n in range(count):
        device, key = devices[n % len(devices)]
        at = now + timedelta(microseconds=n)
        event: dict[str, Any] = {
            "event_id": f"{tag}-{n}",
            "occurred_at": at.isoformat().replace("+00:00", "Z"),
        }
        if mix == "heartbeat" or n % 5 == 4:
            event["kind"] = "heartbeat"
        else:
            event |= {"kind": "axle_count", "section": "AB", "axles": 24}
        out.append((device, key, json.dumps(event).encode()))
    return out


def bench_http(url: str, messages: list[tuple[str, str, bytes]]) -> float:
    def post(chunk: list[tuple[str, str, bytes]]) -> None:
        with httpx.Client(base_url=url, timeout=60) as client:
            for _, key, body in chunk:
                headers = {"X-Device-Key": key, "Content-Type": "application/json"}
                response = client.post("/api/v1/events", content=body, headers=headers)
                assert response.status_code == 201, response.text

    chunks = [messages[k::HTTP_CLIENTS] for k in range(HTTP_CLIENTS)]
    start = time.perf_counter()
    with ThreadPoolExecutor(HTTP_CLIENTS) as pool:
        list(pool.map(post, chunks))
    return len(messages) / (time.perf_counter() - start)


class Collector:
    """Counts answers with status 201 until all expected ones have come."""

    def __init__(self, expected: int) -> None:
        self.expected, self.created, self.other = expected, 0, 0
        self.samples: list[dict[str, Any]] = []  # a few answers other than 201, to show
        self.done = threading.Event()
        self.lock = threading.Lock()

    def record(self, payload: bytes) -> None:
        answer = json.loads(payload)
        with self.lock:
            if answer["http_status"] == 201:
                self.created += 1
            else:
                self.other += 1
                if len(self.samples) < 3:
                    self.samples.append(answer)
            if self.created >= self.expected:
                self.done.set()


def bench_mqtt(prefix: str, messages: list[tuple[str, str, bytes]]) -> float:
    import paho.mqtt.client as mqtt
    from paho.mqtt.enums import CallbackAPIVersion, MQTTProtocolVersion
    from paho.mqtt.packettypes import PacketTypes
    from paho.mqtt.properties import Properties

    collector = Collector(len(messages))
    client = mqtt.Client(CallbackAPIVersion.VERSION2, protocol=MQTTProtocolVersion.MQTTv5)
    client.max_inflight_messages_set(1000)
    client.max_queued_messages_set(0)
    subscribed = threading.Event()
    client.on_subscribe = lambda *_: subscribed.set()
    client.on_message = lambda _c, _u, m: collector.record(bytes(m.payload))
    # Our receive maximum covers every answer we may be owed: Mosquitto would otherwise queue
    # the answers beyond its in-flight window for us and drop those past its queue limit (stock
    # 1000) although they were committed: seen at a load of 20, 429 of 4000 answers lost.
    connect = Properties(PacketTypes.CONNECT)  # type: ignore[no-untyped-call]
    connect.ReceiveMaximum = 2 * MQTT_WINDOW
    client.connect("127.0.0.1", 1883, properties=connect)
    client.subscribe(f"{prefix}/results/+", qos=1)
    client.loop_start()
    assert subscribed.wait(10)
    start = time.perf_counter()
    for sent, (device, key, body) in enumerate(messages):
        while sent - (collector.created + collector.other) >= MQTT_WINDOW:
            time.sleep(0.001)  # the broker would drop what overflows the bridge's queue
        properties = Properties(PacketTypes.PUBLISH)  # type: ignore[no-untyped-call]
        properties.UserProperty = ("device-key", key)
        client.publish(f"{prefix}/events/{device}", body, qos=1, properties=properties)
    assert collector.done.wait(300), (
        f"MQTT: {collector.created} of {len(messages)} created, {collector.samples}"
    )
    elapsed = time.perf_counter() - start
    client.disconnect()
    client.loop_stop()
    assert collector.other == 0, f"MQTT: {collector.other} answers other than 201"
    return len(messages) / elapsed


def bench_nats(prefix: str, messages: list[tuple[str, str, bytes]]) -> float:
    import asyncio

    import nats

    collector = Collector(len(messages))

    async def run() -> float:
        nc = await nats.connect("nats://127.0.0.1:4222")

        async def on_result(msg: Any) -> None:
            collector.record(msg.data)

        await nc.subscribe(f"{prefix}.results.*", cb=on_result)
        js = nc.jetstream()
        start = time.perf_counter()
        for at in range(0, len(messages), 500):
            await asyncio.gather(*(
                js.publish(f"{prefix}.events.{d}", body, headers={"Depot-Device-Key": k})
                for d, k, body in messages[at : at + 500]
            ))  # fmt: skip
        while not collector.done.is_set() and time.perf_counter() - start < 300:
            await asyncio.sleep(0.02)
        elapsed = time.perf_counter() - start
        for suffix in ("EVENTS", "DEAD"):
            await js.delete_stream(f"{prefix.upper()}_{suffix}")
        await nc.close()
        return elapsed

    elapsed = asyncio.run(run())
    assert collector.done.is_set(), (
        f"JetStream: {collector.created} of {len(messages)} created, {collector.samples}"
    )
    assert collector.other == 0, f"JetStream: {collector.other} answers other than 201"
    return len(messages) / elapsed


def _forget_session(client_id: str) -> None:
    """End the bench bridge's persistent session in the broker (clean start, no expiry)."""
    import paho.mqtt.client as mqtt
    from paho.mqtt.enums import CallbackAPIVersion, MQTTProtocolVersion

    client = mqtt.Client(
        CallbackAPIVersion.VERSION2, client_id=client_id, protocol=MQTTProtocolVersion.MQTTv5
    )
    client.connect("127.0.0.1", 1883, clean_start=True)
    client.loop_start()
    time.sleep(0.2)
    client.disconnect()
    client.loop_stop()


def _start(
    env: dict[str, str], command: list[str], ready: str, log: Path, *, times: int = 1
) -> subprocess.Popen[bytes]:
    """Start ``depot COMMAND``; ready when its log says ``ready`` ``times`` times."""
    with open(log, "wb") as out:
        process = subprocess.Popen(
            [DEPOT, *command], env=env, stdout=out, stderr=out, start_new_session=True
        )
    deadline = time.monotonic() + 120
    while log.read_text(errors="replace").count(ready) < times:
        if process.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"depot {command} did not start: {log.read_text()[-2000:]}")
        time.sleep(0.1)
    return process


def _config(env: dict[str, str]) -> MqttConfig:
    """The bench bridge's configuration as ``depot mqtt`` reads it (for its client ids)."""
    return MqttConfig(
        broker_url="mqtt://127.0.0.1:1883",
        client_id=env["DEPOT_MQTT_CLIENT_ID"],
        prefix=env["DEPOT_MQTT_PREFIX"],
        inflight=INFLIGHT,
        batch=BATCH,
        max_bytes=0,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--events", type=int, default=4000, help="messages per transport")
    parser.add_argument("--consumers", type=int, default=2, help="depot consume processes")
    parser.add_argument(
        "--mqtt-workers", type=int, default=MQTT_WORKERS, help="depot mqtt --workers N"
    )
    parser.add_argument(
        "--mix",
        choices=("heartbeat", "mixed"),
        default="heartbeat",
        help="heartbeats (stored, liveness only) or axle counts deriving evidence",
    )
    args = parser.parse_args()
    os.environ.setdefault(
        "DEPOT_TEST_POSTGRES_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/postgres"
    )
    # Named after the database the tests point at, so that two runs side by side (two
    # worktrees, each with its own DEPOT_TEST_POSTGRES_URL) never drop each other's.
    base = os.environ["DEPOT_TEST_POSTGRES_URL"].rsplit("/", 1)[-1]
    database = bench_database(f"{base}_bench_transports")
    tag = uuid.uuid4().hex[:8]
    env = {
        **os.environ,
        "DEPOT_DATABASE_URL": database,
        "DEPOT_DATA_DIR": tempfile.mkdtemp(prefix="depot-bench-transports-"),
        "DEPOT_ADMIN_TOKEN": ADMIN_TOKEN,
        "DEPOT_ENVIRONMENT": "test",
        "DEPOT_MQTT_PREFIX": f"depot-bench/{tag}/v1",
        "DEPOT_MQTT_CLIENT_ID": f"depot-bench-{tag}",
        "DEPOT_NATS_PREFIX": f"bench{tag}",
        "DEPOT_TRANSPORT_BATCH": str(BATCH),
        "DEPOT_MQTT_INFLIGHT": str(INFLIGHT),
    }
    logs = Path(env["DEPOT_DATA_DIR"])
    with serve(database) as url:
        devices = _devices(url)
        mqtt_command = ["mqtt", "--workers", str(args.mqtt_workers)]
        ready = {"times": args.mqtt_workers}
        workers = [_start(env, mqtt_command, "subscribed to", logs / "mqtt.log", **ready)]
        workers += [
            _start(env, ["consume"], "consuming", logs / f"consume-{n}.log")
            for n in range(args.consumers)
        ]
        try:
            http = bench_http(url, _events("http", args.events, devices, args.mix))
            mqtt_events = _events("mqtt", args.events, devices, args.mix)
            mqtt_rate = bench_mqtt(env["DEPOT_MQTT_PREFIX"], mqtt_events)
            nats_events = _events("nats", args.events, devices, args.mix)
            nats_rate = bench_nats(env["DEPOT_NATS_PREFIX"], nats_events)
        finally:
            for process in workers:
                os.killpg(process.pid, signal.SIGTERM)
                process.wait(timeout=30)
            for one in worker_configs(_config(env), args.mqtt_workers):
                _forget_session(one.client_id)
    where = database.split("@")[-1]
    print(f"{args.events} single-event messages ({args.mix}) per transport into {where}")
    print(f"  HTTP  POST /events ({HTTP_CLIENTS} clients, 2 workers): {http:8.0f} events/s")
    bridges = f"{args.mqtt_workers} bridge workers, receive max {INFLIGHT} each"
    print(f"  MQTT  depot mqtt ({bridges}): {mqtt_rate:8.0f} events/s")
    print(f"  NATS  depot consume ({args.consumers} consumers):       {nats_rate:8.0f} events/s")
    print(f"  (broker transports: at most {BATCH} messages per commit)")
    print(f"  ratios to HTTP: MQTT {mqtt_rate / http:.2f}, JetStream {nats_rate / http:.2f}")


if __name__ == "__main__":
    main()
