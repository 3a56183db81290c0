"""``depot mqtt``: the bridge from an MQTT 5 broker to the ingest service.

Devices publish (QoS 1) to ``{prefix}/events/{device_id}`` with their key in the user
property ``device-key``. The bridge holds a shared subscription (several bridges split the
load) in a persistent session under a stable client id, and acknowledges a message (PUBACK,
sent by hand) only after the transaction that stored it has committed: a bridge that dies
before that gets the message again when it comes back, and idempotency drops the repeat.

Three threads: paho's network thread queues what arrives; the main thread stores a batch
(one transaction for all its devices) and hands the committed batch to the answer thread,
which publishes each answer and then acknowledges its message while the next batch is stored.
MQTT tells nothing of when the broker got a message: an event's receive time (which liveness
counts from) is when the network thread read it, bounded by the event's own ``occurred_at``,
so that a backlog read after a restart does not make a silent device look alive.
"""

from __future__ import annotations

import logging
import queue
import signal
import threading
import time
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit

import paho.mqtt.client as mqtt
from paho.mqtt.enums import CallbackAPIVersion, MQTTProtocolVersion
from paho.mqtt.packettypes import PacketTypes
from paho.mqtt.properties import Properties
from sqlalchemy.orm import Session, sessionmaker

from core.database import utcnow
from transports.envelope import DATABASE_DOWN, Answer, Message, handle_batch
from transports.stats import BatchStats

log = logging.getLogger("depot.mqtt")
SESSION_EXPIRY_S = 7 * 24 * 3600  # a bridge down for a week still finds its queued messages
SHARE_GROUP = "depot"
KEY_PROPERTY = "device-key"
# How long a batch waits for more messages after its first: a burst is committed together
# (one commit, a few statements per device) at the price of this much latency when idle.
LINGER_S = 0.02


@dataclass(frozen=True)
class MqttConfig:
    broker_url: str
    client_id: str
    prefix: str
    inflight: int  # MQTT 5 receive maximum: messages the broker may have unacknowledged with us
    batch: int  # messages committed together, at most
    max_bytes: int

    @property
    def subscription(self) -> str:
        return f"$share/{SHARE_GROUP}/{self.prefix}/events/+"


def broker_address(url: str) -> tuple[str, int]:
    """``mqtt://host:port`` (also ``tcp://``) as (host, port); port 1883 when not given."""
    parts = urlsplit(url if "://" in url else f"mqtt://{url}")
    if parts.scheme not in ("mqtt", "tcp") or not parts.hostname:
        raise ValueError(f"not an MQTT broker URL: {url!r}; write mqtt://HOST:PORT")
    return parts.hostname, parts.port or 1883


@dataclass(frozen=True)
class _Incoming:
    mid: int
    qos: int
    connection: int  # a packet id means something only on the connection it came on
    message: Message
    correlation: bytes | None


def _properties(packet_type: int) -> Properties:
    return Properties(packet_type)  # type: ignore[no-untyped-call]  # paho's is untyped


def _user_property(properties: Properties | None, name: str) -> str | None:
    for key, value in getattr(properties, "UserProperty", None) or ():
        if key == name:
            return str(value)
    return None


class Bridge:
    """One bridge process: the network thread queues messages, the main thread commits them."""

    def __init__(self, sessions: sessionmaker[Session], config: MqttConfig) -> None:
        self.sessions, self.config = sessions, config
        self.incoming: queue.Queue[_Incoming] = queue.Queue()
        # Committed batches, to be answered; bounded so that answering keeps up with storing.
        self.committed: queue.Queue[tuple[list[_Incoming], list[Answer]] | None] = queue.Queue(
            maxsize=2
        )
        self.stopping = threading.Event()
        self.signalled = False
        self.connection = 0
        self.stats = BatchStats(log)
        self.client = mqtt.Client(
            CallbackAPIVersion.VERSION2,
            client_id=config.client_id,
            protocol=MQTTProtocolVersion.MQTTv5,
            manual_ack=True,
        )
        self.client.on_connect = self._on_connect
        self.client.on_message = self._on_message
        self.client.on_subscribe = lambda *_: log.info("subscribed to %s", config.subscription)
        self.client.reconnect_delay_set(min_delay=1, max_delay=10)
        # Answers are sent at once, never held back behind paho's window of unacknowledged
        # publishes: an acknowledgement must not leave before the answer that precedes it.
        self.client.max_inflight_messages_set(0)
        self.client.max_queued_messages_set(0)

    def _on_connect(self, client: mqtt.Client, _: Any, flags: Any, code: Any, __: Any) -> None:
        if code.is_failure:
            log.error("the broker refused the connection: %s", code)
            return
        self.connection += 1
        log.info(
            "connected as %s (session present: %s); subscribing to %s",
            self.config.client_id,
            flags.session_present,
            self.config.subscription,
        )
        client.subscribe(self.config.subscription, qos=1)

    def _on_message(self, _: mqtt.Client, __: Any, msg: mqtt.MQTTMessage) -> None:
        device_id = msg.topic.rsplit("/", 1)[-1]
        properties = getattr(msg, "properties", None)
        key = _user_property(properties, KEY_PROPERTY)
        self.incoming.put(
            _Incoming(
                mid=msg.mid,
                qos=msg.qos,
                connection=self.connection,
                # MQTT says nothing of when the broker got it: the read bounds the receive
                # time, the event's own occurred_at bounds it too (a backlog read late)
                message=Message(
                    device_id, key, bytes(msg.payload), received_at=utcnow(), received_is_read=True
                ),
                correlation=getattr(properties, "CorrelationData", None),
            )
        )

    def _take(self) -> list[_Incoming]:
        """The next batch: up to ``batch`` messages, collected for at most ``LINGER_S`` after
        the first; [] after a quiet 0.5 s."""
        try:
            items = [self.incoming.get(timeout=0.5)]
        except queue.Empty:
            return []
        until = time.monotonic() + LINGER_S
        while len(items) < self.config.batch:
            left = until - time.monotonic()
            try:
                items.append(
                    self.incoming.get(timeout=left) if left > 0 else self.incoming.get_nowait()
                )
            except queue.Empty:
                break
        return items

    def _commit(self, items: list[_Incoming]) -> list[Answer] | None:
        """Store the batch; while the database is down, keep the messages and try again."""
        delay = 0.5
        while not self.stopping.is_set():
            try:
                started = time.monotonic()
                answers = handle_batch(
                    self.sessions,
                    [i.message for i in items],
                    transport="mqtt",
                    max_bytes=self.config.max_bytes,
                )
                self.stats.record(len(items), time.monotonic() - started)
                return answers
            except DATABASE_DOWN as exc:
                name = type(exc).__name__
                log.warning("database unavailable (%s); retrying in %.1f s", name, delay)
                time.sleep(delay)
                delay = min(delay * 2, 10.0)
        return None  # stopping: unacknowledged, the broker gives them to us again

    def _answer(self, item: _Incoming, answer: Answer) -> None:
        properties = None
        if item.correlation is not None:
            properties = _properties(PacketTypes.PUBLISH)
            properties.CorrelationData = item.correlation
        topic = f"{self.config.prefix}/results/{item.message.device_id}"
        self.client.publish(topic, answer.to_json(), qos=1, properties=properties)
        if item.connection == self.connection:
            self.client.ack(item.mid, item.qos)

    def _answering(self) -> None:
        """The answer thread: answers and acknowledges committed batches, in commit order,
        while the main thread stores the next batch. ``None`` ends it."""
        failed = False
        while (done := self.committed.get()) is not None:
            if failed:
                continue  # unacknowledged: the broker sends them again to the next bridge
            try:
                for item, answer in zip(*done, strict=True):
                    self._answer(item, answer)
            except Exception:  # a bug: stop rather than hold messages unacknowledged forever
                log.exception("answering failed; the bridge stops")
                failed = True
                self.stopping.set()

    def _on_signal(self, *_: Any) -> None:
        """Stop once. A second signal can land while the first handler is inside
        ``Event.set`` (its lock is not reentrant): it must not call it again, or the bridge
        hangs (seen: the group's SIGTERM and the ``--workers`` parent's one back to back)."""
        if not self.signalled:
            self.signalled = True
            self.stopping.set()

    def serve(self) -> None:
        """Run until SIGTERM or SIGINT; the batch in hand is finished first."""
        host, port = broker_address(self.config.broker_url)
        connect = _properties(PacketTypes.CONNECT)
        connect.SessionExpiryInterval = SESSION_EXPIRY_S
        connect.ReceiveMaximum = self.config.inflight
        self.client.connect_async(host, port, clean_start=False, properties=connect)
        self.client.loop_start()
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, self._on_signal)
        answering = threading.Thread(target=self._answering, name="answers", daemon=True)
        answering.start()
        try:
            while not self.stopping.is_set():
                items = self._take()
                answers = self._commit(items) if items else None
                if answers is not None:
                    self.committed.put((items, answers))
        finally:
            self.committed.put(None)  # what is committed is answered and acknowledged first
            answering.join()
            self.client.disconnect()
            self.client.loop_stop()
