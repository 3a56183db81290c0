"""Real brokers and real processes for the transport tests: bridges, consumers, devices.

Each run uses its own MQTT topic prefix, NATS stream prefix and bridge client id, so runs on
one machine never see each other's messages; what a run leaves in the brokers (streams, the
bridge's persistent session) is removed at the end.
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import subprocess
import threading
import time
import uuid
from collections import defaultdict
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

import nats
import paho.mqtt.client as mqtt
import pytest
from nats.js.errors import NotFoundError
from paho.mqtt.enums import CallbackAPIVersion, MQTTProtocolVersion
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties
from sqlalchemy.orm import Session, sessionmaker

from core.auth import hash_secret
from core.models import Device, Station
from tests.reliability.relkit import DEPOT

MQTT_HOST, MQTT_PORT = "127.0.0.1", 1883
NATS_HOST, NATS_PORT = "127.0.0.1", 4222
NATS_URL = f"nats://{NATS_HOST}:{NATS_PORT}"
Key = tuple[str, str | None]  # (device, event_id); None when the answer names no event


def require_broker(name: str, host: str, port: int) -> None:
    """Skip (with the reason) when the broker does not listen; the tests need the real one."""
    try:
        with socket.create_connection((host, port), timeout=2):
            return
    except OSError as exc:
        pytest.skip(f"{name} not reachable at {host}:{port} ({exc}); start it to run this test")


class RunNames:
    """This run's prefixes: ``DEPOT_MQTT_PREFIX``, ``DEPOT_NATS_PREFIX``, the bridge's id."""

    def __init__(self) -> None:
        tag = f"{os.getpid()}{uuid.uuid4().hex[:8]}"
        self.mqtt_prefix = f"depot-test/{tag}/v1"
        self.nats_prefix = f"t{tag}"
        self.client_id = f"depot-test-bridge-{tag}"

    def env(self) -> dict[str, str]:
        return {
            "DEPOT_MQTT_PREFIX": self.mqtt_prefix,
            "DEPOT_MQTT_CLIENT_ID": self.client_id,
            "DEPOT_NATS_PREFIX": self.nats_prefix,
        }


class Process:
    """A ``depot`` command in its own process group, ready when its log says ``ready``."""

    def __init__(self, env: dict[str, str], log_path: Path, *args: str, ready: str) -> None:
        self.env, self.log_path, self.args, self.ready = env, log_path, args, ready
        self.process: subprocess.Popen[bytes] | None = None
        self.offset = 0

    def launch(self) -> None:
        self.offset = self.log_path.stat().st_size if self.log_path.exists() else 0
        with open(self.log_path, "ab") as log:
            self.process = subprocess.Popen(
                [DEPOT, *self.args], env=self.env, stdout=log, stderr=log, start_new_session=True
            )

    def wait_ready(self, *, within: float = 90) -> None:
        assert self.process is not None, "launch() first"
        deadline = time.monotonic() + within
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"depot {self.args[0]} exited: {self.log_text()[-2000:]}")
            if self.ready in self.log_text()[self.offset :]:
                return
            time.sleep(0.1)
        self.kill()
        raise RuntimeError(f"depot {self.args[0]} not ready in {within} s: {self.log_text()}")

    def start(self) -> None:
        self.launch()
        self.wait_ready()

    def log_text(self) -> str:
        return self.log_path.read_text(errors="replace") if self.log_path.exists() else ""

    def _signal(self, sig: int, wait: float) -> None:
        if self.process is None or self.process.poll() is not None:
            return
        os.killpg(self.process.pid, sig)
        try:
            self.process.wait(timeout=wait)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait(timeout=10)

    def kill(self) -> None:
        """SIGKILL: nothing is finished, nothing acknowledged that was not already."""
        self._signal(signal.SIGKILL, 10)

    def stop(self) -> None:
        self._signal(signal.SIGTERM, 20)


def bridge(env: dict[str, str], data_dir: Path) -> Process:
    return Process(env, data_dir / "mqtt.log", "mqtt", ready="subscribed to")


def consumer(env: dict[str, str], data_dir: Path, n: int) -> Process:
    return Process(env, data_dir / f"consume-{n}.log", "consume", ready="consuming")


class Answers:
    """Every answer the devices received on the results topics, by (device, event_id)."""

    def __init__(self) -> None:
        self.lock = threading.Condition()
        self.by_key: dict[Key, list[int]] = defaultdict(list)
        self.bodies: list[tuple[str, dict[str, Any]]] = []

    def record(self, device_id: str, payload: bytes) -> None:
        body = json.loads(payload)
        with self.lock:
            self.bodies.append((device_id, body))
            for event_id, status in _statuses(body):
                self.by_key[(device_id, event_id)].append(status)
            self.lock.notify_all()

    def wait_for(self, keys: set[Key], *, within: float) -> set[Key]:
        """Wait until every key has an answer; returns those still without one."""
        deadline = time.monotonic() + within
        with self.lock:
            while True:
                missing = {k for k in keys if k not in self.by_key}
                left = deadline - time.monotonic()
                if not missing or left <= 0:
                    return missing
                self.lock.wait(timeout=min(left, 0.5))


def _statuses(body: dict[str, Any]) -> list[tuple[str | None, int]]:
    if "results" in body:  # a batch: each item carries its own outcome
        codes = {"created": 201, "duplicate": 200}
        return [
            (r.get("event_id"), codes.get(r["status"]) or int(r["error"]["status"]))
            for r in body["results"]
        ]
    return [(body.get("event_id"), int(body["http_status"]))]


class MqttDevices:
    """Devices publishing QoS 1 through Mosquitto, listening to their results topics."""

    def __init__(self, prefix: str, answers: Answers) -> None:
        self.prefix, self.answers = prefix, answers
        self.client = mqtt.Client(
            CallbackAPIVersion.VERSION2,
            client_id=f"devices-{uuid.uuid4().hex[:12]}",
            protocol=MQTTProtocolVersion.MQTTv5,
        )
        self.client.max_queued_messages_set(0)
        self.client.max_inflight_messages_set(1000)
        subscribed = threading.Event()
        self.client.on_subscribe = lambda *_: subscribed.set()
        self.client.on_message = lambda _c, _u, m: answers.record(
            m.topic.rsplit("/", 1)[-1], bytes(m.payload)
        )
        self.client.connect(MQTT_HOST, MQTT_PORT)
        self.client.subscribe(f"{prefix}/results/+", qos=1)
        self.client.loop_start()
        assert subscribed.wait(10), "the results subscription was not confirmed"

    def publish(self, device_id: str, key: str | None, payload: bytes) -> mqtt.MQTTMessageInfo:
        properties = Properties(PacketTypes.PUBLISH)  # type: ignore[no-untyped-call]
        if key is not None:
            properties.UserProperty = ("device-key", key)
        topic = f"{self.prefix}/events/{device_id}"
        return self.client.publish(topic, payload, qos=1, properties=properties)

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


class NatsDevices:
    """Devices publishing to JetStream (stream ack awaited), listening to their results."""

    def __init__(self, prefix: str, answers: Answers) -> None:
        self.prefix, self.answers = prefix, answers
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.nc: Any = self.call(self._connect())

    def call(self, coroutine: Any, timeout: float = 60) -> Any:
        future: Future[Any] = asyncio.run_coroutine_threadsafe(coroutine, self.loop)
        return future.result(timeout=timeout)

    async def _connect(self) -> Any:
        nc = await nats.connect(NATS_URL)

        async def on_result(msg: Any) -> None:
            self.answers.record(msg.subject.rsplit(".", 1)[-1], msg.data)

        await nc.subscribe(f"{self.prefix}.results.*", cb=on_result)
        await nc.flush()
        return nc

    async def _publish_all(self, items: list[tuple[str, str | None, bytes]]) -> None:
        js = self.nc.jetstream()
        tasks = []
        for device_id, key, payload in items:
            headers = {"Depot-Device-Key": key} if key is not None else None
            subject = f"{self.prefix}.events.{device_id}"
            tasks.append(js.publish(subject, payload, headers=headers, timeout=30))
        for start in range(0, len(tasks), 500):  # bounded number of outstanding stream acks
            await asyncio.gather(*tasks[start : start + 500])

    def publish_all(self, items: list[tuple[str, str | None, bytes]]) -> None:
        self.call(self._publish_all(items), timeout=120)

    def consumer_info(self, stream: str, consumer: str) -> Any:
        return self.call(self.nc.jetstream().consumer_info(stream, consumer))

    def stream_messages(self, stream: str) -> int:
        async def count() -> int:
            try:
                return int((await self.nc.jetstream().stream_info(stream)).state.messages)
            except NotFoundError:
                return 0

        return int(self.call(count()))

    def dead_letters(self, stream: str, subject: str) -> list[Any]:
        async def fetch() -> list[Any]:
            js = self.nc.jetstream()
            sub = await js.pull_subscribe(subject, stream=stream)
            try:
                return list(await sub.fetch(100, timeout=2))
            except nats.errors.TimeoutError:
                return []

        return list(self.call(fetch()))

    def delete_streams(self, prefix: str) -> None:
        async def delete() -> None:
            js = self.nc.jetstream()
            for suffix in ("EVENTS", "DEAD"):
                with suppress(NotFoundError):
                    await js.delete_stream(f"{prefix.upper()}_{suffix}")

        self.call(delete())

    def close(self) -> None:
        self.call(self.nc.close())
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(timeout=5)


def forget_session(client_id: str) -> None:
    """End the bridge's persistent session in Mosquitto (clean start, session expiry 0)."""
    client = mqtt.Client(
        CallbackAPIVersion.VERSION2, client_id=client_id, protocol=MQTTProtocolVersion.MQTTv5
    )
    try:
        client.connect(MQTT_HOST, MQTT_PORT, clean_start=True)
        client.loop_start()
        time.sleep(0.2)
        client.disconnect()
        client.loop_stop()
    except OSError:
        pass


@contextmanager
def brokers(names: RunNames) -> Iterator[tuple[Answers, MqttDevices, NatsDevices]]:
    require_broker("Mosquitto (MQTT)", MQTT_HOST, MQTT_PORT)
    require_broker("NATS JetStream", NATS_HOST, NATS_PORT)
    answers = Answers()
    mqtt_devices = MqttDevices(names.mqtt_prefix, answers)
    nats_devices = NatsDevices(names.nats_prefix, answers)
    try:
        yield answers, mqtt_devices, nats_devices
    finally:
        nats_devices.delete_streams(names.nats_prefix)
        nats_devices.close()
        mqtt_devices.close()
        forget_session(names.client_id)


def until(condition: Callable[[], bool], *, within: float, what: str) -> None:
    """Wait (bounded) for ``condition``; fail naming ``what`` did not happen."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.1)
    raise AssertionError(f"waited {within} s in vain for: {what}")


def register_devices(sessions: sessionmaker[Session], station: str, keys: dict[str, str]) -> None:
    """A station and its axle counters, each with its key (device id → key), committed."""
    with sessions.begin() as session:
        session.add(Station(id=station, name=station))
        session.flush()
        session.add_all(
            Device(id=d, station=station, kind="axle_counter", key_hash=hash_secret(k))
            for d, k in keys.items()
        )
