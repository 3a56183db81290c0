"""``depot consume``: the durable JetStream pull consumer feeding the ingest service.

Devices (or their station's leaf node) publish to ``{prefix}.events.{device_id}`` with the
header ``Depot-Device-Key``. Every ``depot consume`` process binds the same durable consumer
``depot-ingest``, so the stream's messages are split between them; each message is acked only
after the transaction that stored it has committed. A message a consumer never acked comes
again after ``ack_wait``; one delivered ``max_deliver`` times without being stored goes, with
the reason, to ``{prefix}.dead.{device_id}`` (kept in its own stream), never silently dropped.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import signal
import time
from dataclasses import dataclass

import nats
from nats.aio.client import Client as NATS
from nats.aio.msg import Msg
from nats.js import JetStreamContext
from nats.js.api import AckPolicy, ConsumerConfig, StorageType, StreamConfig
from nats.js.errors import NotFoundError
from sqlalchemy.orm import Session, sessionmaker

from transports.envelope import DATABASE_DOWN, Answer, Message, handle_batch
from transports.stats import BatchStats

log = logging.getLogger("depot.consume")
CONSUMER = "depot-ingest"
KEY_HEADER = "Depot-Device-Key"
MAX_NAK_DELAY_S = 30.0


@dataclass(frozen=True)
class StreamNames:
    """Stream and subjects named by ``DEPOT_NATS_PREFIX`` (``t1`` → ``T1_EVENTS``, ``t1.*``)."""

    prefix: str

    @property
    def stream(self) -> str:
        return f"{self.prefix.upper().replace('-', '_')}_EVENTS"

    @property
    def dead_stream(self) -> str:
        return f"{self.prefix.upper().replace('-', '_')}_DEAD"

    @property
    def events(self) -> str:
        return f"{self.prefix}.events.*"

    def results(self, device_id: str) -> str:
        return f"{self.prefix}.results.{device_id}"

    def dead(self, device_id: str) -> str:
        return f"{self.prefix}.dead.{device_id}"


@dataclass(frozen=True)
class ConsumeConfig:
    url: str
    names: StreamNames
    replicas: int
    ack_wait_s: float
    max_deliver: int
    batch: int
    max_bytes: int


async def ensure_streams(js: JetStreamContext, config: ConsumeConfig) -> None:
    """The events stream and the dead-letter stream (file storage), created when missing."""
    names = config.names
    for name, subject in ((names.stream, names.events), (names.dead_stream, names.dead("*"))):
        try:
            await js.stream_info(name)
        except NotFoundError:
            log.info("creating stream %s for %s", name, subject)
            await js.add_stream(
                StreamConfig(
                    name=name,
                    subjects=[subject],
                    storage=StorageType.FILE,
                    num_replicas=config.replicas,
                )
            )


async def ensure_consumer(js: JetStreamContext, config: ConsumeConfig) -> None:
    # No bound on the server: JetStream counts deliveries a consumer never saw (one killed
    # holding its batch, a fetch that expired as the message arrived) and, at its bound, would
    # stop delivering without telling anyone. We bound deliveries ourselves (``_handle``): every
    # message is either stored or dead-lettered with its reason.
    await js.add_consumer(
        config.names.stream,
        ConsumerConfig(
            durable_name=CONSUMER,
            ack_policy=AckPolicy.EXPLICIT,
            ack_wait=config.ack_wait_s,
            max_deliver=-1,
            filter_subject=config.names.events,
            max_ack_pending=max(1000, 4 * config.batch),
        ),
    )


def _message(msg: Msg) -> Message:
    """The message as the envelope takes it; received when the stream stored it (its metadata
    timestamp, the same on every redelivery), so a backlog does not make a silent device look
    alive: liveness counts from when the device spoke to the stream, not when we read it."""
    device_id = msg.subject.rsplit(".", 1)[-1]
    key = (msg.headers or {}).get(KEY_HEADER)
    return Message(device_id, key, msg.data, received_at=msg.metadata.timestamp)


class Consumer:
    def __init__(self, sessions: sessionmaker[Session], config: ConsumeConfig) -> None:
        self.sessions, self.config = sessions, config
        self.failures: dict[int, str] = {}  # stream sequence → why its last delivery failed
        self.stopping = asyncio.Event()
        self.stats = BatchStats(log)

    async def _dead_letter(self, js: JetStreamContext, msg: Msg, deliveries: int) -> None:
        sequence = msg.metadata.sequence.stream
        reason = self.failures.pop(
            sequence, "not acknowledged in time (the consumer stopped or the database was down)"
        )
        device_id = _message(msg).device_id
        headers = {
            "Depot-Dead-Reason": f"failed {deliveries} deliveries; last: {reason}",
            "Depot-Stream-Sequence": str(sequence),
        }
        await js.publish(self.config.names.dead(device_id), msg.data, headers=headers)
        log.error("message %d from %s dead-lettered: %s", sequence, device_id, reason)
        await msg.ack()

    async def _retry(self, js: JetStreamContext, msg: Msg) -> None:
        """A failed delivery comes again later, unless it was the last one allowed."""
        delivered = msg.metadata.num_delivered
        if delivered >= self.config.max_deliver:
            await self._dead_letter(js, msg, delivered)
        else:
            await msg.nak(delay=min(2.0**delivered, MAX_NAK_DELAY_S))

    async def _settle(self, nc: NATS, js: JetStreamContext, msg: Msg, answer: Answer) -> None:
        sequence = msg.metadata.sequence.stream
        if answer.retry:
            self.failures[sequence] = str(answer.body.get("detail"))
            await self._retry(js, msg)
            return
        self.failures.pop(sequence, None)
        device_id = _message(msg).device_id
        await nc.publish(self.config.names.results(device_id), answer.to_json())
        await msg.ack()

    async def _handle(self, nc: NATS, js: JetStreamContext, msgs: list[Msg]) -> None:
        live = []
        for msg in msgs:
            if msg.metadata.num_delivered > self.config.max_deliver:  # earlier ones unanswered
                await self._dead_letter(js, msg, msg.metadata.num_delivered - 1)
            else:
                live.append(msg)
        if not live:
            return
        started = time.monotonic()
        try:
            answers = await asyncio.to_thread(
                handle_batch,
                self.sessions,
                [_message(m) for m in live],
                transport="nats",
                max_bytes=self.config.max_bytes,
            )
        except DATABASE_DOWN as exc:
            log.warning("database unavailable (%s); %d messages come again", exc, len(live))
            for msg in live:
                self.failures[msg.metadata.sequence.stream] = f"database unavailable ({exc})"
                await self._retry(js, msg)
            return
        self.stats.record(len(live), time.monotonic() - started)
        for msg, answer in zip(live, answers, strict=True):
            await self._settle(nc, js, msg, answer)

    async def run(self) -> None:
        """Consume until SIGTERM or SIGINT; the batch in hand is finished first."""
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, self.stopping.set)
        nc = await nats.connect(self.config.url, max_reconnect_attempts=-1, reconnect_time_wait=1)
        js = nc.jetstream()
        await ensure_streams(js, self.config)
        await ensure_consumer(js, self.config)
        subscription = await js.pull_subscribe_bind(CONSUMER, stream=self.config.names.stream)
        log.info("consuming %s as %s", self.config.names.events, CONSUMER)
        try:
            while not self.stopping.is_set():
                try:
                    msgs = await subscription.fetch(self.config.batch, timeout=1)
                except TimeoutError:  # nats-py raises its own or asyncio's: both are this
                    continue
                except nats.errors.Error as exc:  # the server went away: the client reconnects
                    log.warning("fetch failed (%s); trying again", exc)
                    await asyncio.sleep(1)
                    continue
                await self._handle(nc, js, msgs)
        finally:
            # The acks already sent leave now; drain() can wait on the pull subscription.
            with contextlib.suppress(nats.errors.Error, TimeoutError):
                await nc.flush(timeout=5)
            await nc.close()
