"""The device protocol without HTTP: one broker message in, one answer out.

A message is what ``POST /events`` takes as its body (one event or ``{"events": [...]}``), a
device id (from the topic or subject) and the device key (from a user property or header).
The answer is the HTTP answer's body plus ``http_status``. Messages are handled in batches:
a batch is stored in one transaction with one ``accept_batch`` per device, so the broker can be
acknowledged for every message of it after one commit, and one bad message never disturbs
the others (it is refused by itself, or the batch is redone message by message).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.exc import DataError, InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.orm import Session, sessionmaker

from core.auth import device_cache, device_for_key, hash_secret
from core.errors import (
    DepotError,
    PayloadTooLarge,
    Unauthorized,
    Unprocessable,
)
from core.models import Device
from ingest.batches import MAX_EVENTS, batch_events
from ingest.multi_store import DeviceBatch, accept_batches
from ingest.payload import read_json

log = logging.getLogger("depot.transports")
MAX_IDS = MAX_EVENTS  # a refused batch names at most as many event ids as a batch may hold

# The database failed: nothing of the batch is committed, so nothing may be acknowledged.
DATABASE_DOWN = (OperationalError, InterfaceError, PendingRollbackError)


class InternalError(DepotError):
    """A failure of the service itself (a bug): nothing stored; the message may come again."""

    status, title = 500, "Internal error"


@dataclass(frozen=True)
class Message:
    """One message from a broker, before anything is known to be right about it.

    ``received_at``: when the transport received it (JetStream: when the stream stored it;
    MQTT: when the bridge read it), the events' receive time for liveness; None: when stored.
    ``received_is_read``: ``received_at`` is only when the bridge read it (MQTT), maybe long
    after the broker got it; each event's receive time is then at most its own occurred_at.
    """

    device_id: str
    key: str | None
    payload: bytes
    received_at: datetime | None = None
    received_is_read: bool = False


@dataclass(frozen=True)
class Answer:
    """What the device is told; ``retry``: an unexpected failure, nothing stored, try again."""

    status: int
    body: dict[str, Any]
    retry: bool = False

    def to_json(self) -> bytes:
        return json.dumps({**self.body, "http_status": self.status}, default=str).encode()


def _problem(exc: DepotError, names: Mapping[str, Any]) -> dict[str, Any]:
    body: dict[str, Any] = {
        "type": "about:blank",
        "title": exc.title,
        "status": exc.status,
        "detail": exc.detail,
    }
    if exc.errors is not None:
        body["errors"] = exc.errors
    return {**body, **names}


def _ids(payload: Any) -> dict[str, Any]:
    """The event ids a payload names, so that a device can tell which message an answer is
    for: ``event_id`` of one event, ``event_ids`` (one per item, None where unreadable) of a
    batch; nothing when it names none."""
    if not isinstance(payload, dict):
        return {}
    events = payload.get("events")
    if isinstance(events, list):
        return {"event_ids": [_event_id(item) for item in events[:MAX_IDS]]}
    event_id = _event_id(payload)
    return {} if event_id is None else {"event_id": event_id}


def _names(message: Message, payload: Any, max_bytes: int, exc: DepotError) -> dict[str, Any]:
    """The device and event ids a refusal names. A message refused for its key was never
    read: it is read here (bounded by ``max_bytes``, nothing of it is believed or stored) only
    to name its event ids, so the device can match the refusal to what it sent."""
    if payload is None and isinstance(exc, Unauthorized):
        try:
            payload = decode(message.payload, max_bytes)
        except DepotError:
            payload = None
    return {"device": message.device_id, **_ids(payload)}


def _refusal(exc: DepotError, message: Message, payload: Any, max_bytes: int) -> Answer:
    return Answer(exc.status, _problem(exc, _names(message, payload, max_bytes, exc)))


def decode(data: bytes, max_bytes: int) -> Any:
    """The JSON of a payload, as ``POST /events`` reads its body (413 and 422 alike)."""
    if len(data) > max_bytes:
        raise PayloadTooLarge(f"the payload has {len(data)} bytes; the limit is {max_bytes}")
    return read_json(data, what="payload")


def devices_for_keys(session: Session, keys: set[str]) -> dict[str, Device]:
    """The registered devices of ``keys`` by key: fresh entries of the key cache shared with
    HTTP (``DEPOT_DEVICE_KEY_TTL_S``), the others with one query for the whole batch."""
    cache = device_cache()
    found = {key: device for key in keys if (device := cache.peek(key)) is not None}
    digests = {hash_secret(key): key for key in keys - found.keys()}
    if digests:
        looked_up = list(session.scalars(select(Device).where(Device.key_hash.in_(digests))))
        # kept for the next batches (the cache's TTL bounds how late a new key or a
        # decommissioning is seen, as over HTTP): else every batch asks for every key again
        for device in cache.remember(looked_up):
            found[digests[device.key_hash or ""]] = device
    return found


def authenticate(
    session: Session, message: Message, known: Mapping[str, Device] | None = None
) -> Device:
    """The registered device whose key came with the message and whose id names the topic.

    ``known``: the batch's devices by key (:func:`devices_for_keys`); else looked up through
    the same key cache as ``X-Device-Key`` on HTTP (bounded staleness).
    """
    if not message.key:
        raise Unauthorized("the device key is missing; send it as 'device-key' / Depot-Device-Key")
    key = message.key
    device = device_for_key(session, key) if known is None else known.get(key)
    if device is None or device.id != message.device_id:
        raise Unauthorized(
            f"the key is not that of a registered device {message.device_id!r}; "
            "register the device to get a key, and publish under its own id"
        )
    if device.decommissioned_at is not None:
        raise Unauthorized(f"device {device.id} is decommissioned; its events are refused")
    return device


def accept(
    session: Session, device: Device, payload: Any, transport: str, message: Message
) -> Answer:
    """One payload, single event or batch, answered as ``POST /events`` answers it."""
    events = batch_events(payload)
    items = [payload] if events is None else events
    received: list[datetime | None] = [message.received_at] * len(items)
    batch = DeviceBatch(device, items, received, message.received_is_read)
    (results,) = accept_batches(session, [batch], transport=transport)
    if events is None:
        return _item_answer(results[0], device.id)
    return Answer(200, {"results": results})


def _event_id(payload: Any) -> str | None:
    event_id = payload.get("event_id") if isinstance(payload, dict) else None
    return event_id if isinstance(event_id, str) else None


def _handle(session: Session, message: Message, transport: str, max_bytes: int) -> Answer:
    """One message in its own savepoint: whatever goes wrong with it stays with it."""
    payload: Any = None
    try:
        with session.begin_nested():
            device = authenticate(session, message)
            payload = decode(message.payload, max_bytes)
            answer = accept(session, device, payload, transport, message)
        return answer
    except DepotError as exc:
        return _refusal(exc, message, payload, max_bytes)
    except DataError:  # a NUL character or an out-of-range number, as in the HTTP app
        refused = Unprocessable("a value cannot be stored or looked up")
        return _refusal(refused, message, payload, max_bytes)
    except DATABASE_DOWN:
        raise
    except Exception as exc:
        log.exception("message from %s failed", message.device_id)
        failure = InternalError(f"the message could not be handled ({type(exc).__name__})")
        answer = _refusal(failure, message, payload, max_bytes)
        return Answer(answer.status, answer.body, retry=True)


@dataclass(frozen=True)
class _Part:
    """The events one message brought: where its answer goes, and how it is shaped."""

    index: int
    events: list[Any]
    batch: bool  # sent as {"events": [...]}: answered with "results", as POST /events
    message: Message


def _item_answer(item: dict[str, Any], device_id: str) -> Answer:
    """The single-event answer of a batch item (what ``accept_event`` answers for it); a
    refusal names the device and, when it has one, the event."""
    if item["status"] == "created":
        return Answer(201, item["result"])
    if item["status"] == "duplicate":
        return Answer(200, item["result"])
    error = item["error"]
    body: dict[str, Any] = {"type": "about:blank", **error, "device": device_id}
    if isinstance(item.get("event_id"), str):
        body["event_id"] = item["event_id"]
    return Answer(int(error["status"]), body)


def _sorted_parts(
    session: Session, messages: Sequence[Message], max_bytes: int, answers: list[Answer | None]
) -> dict[str, tuple[Device, list[_Part]]]:
    """Check key, size and JSON of each message; refusals go into ``answers`` at once.

    Returns the accepted messages' events by device, in the order that takes the sections'
    locks as the group commit does (two consumers' batches lock in the same order).
    """
    parts: dict[str, tuple[Device, list[_Part]]] = {}
    known = devices_for_keys(session, {m.key for m in messages if m.key})
    for index, message in enumerate(messages):
        payload: Any = None
        try:
            device = authenticate(session, message, known)
            payload = decode(message.payload, max_bytes)
            events = batch_events(payload)
        except DepotError as exc:
            answers[index] = _refusal(exc, message, payload, max_bytes)
            continue
        part = _Part(index, [payload] if events is None else events, events is not None, message)
        parts.setdefault(device.id, (device, []))[1].append(part)
    order = sorted(parts, key=lambda d: (parts[d][0].section or "", d))
    return {d: parts[d] for d in order}


def _grouped(
    session: Session, messages: Sequence[Message], transport: str, max_bytes: int
) -> list[Answer]:
    """The batch's events, every device's, stored with a few statements in all (one raw
    insert), not a few per device or per message. Each event is validated and answered by
    itself, as in a batch over HTTP."""
    answers: list[Answer | None] = [None] * len(messages)
    by_device = list(_sorted_parts(session, messages, max_bytes, answers).values())
    batches = [
        DeviceBatch(
            device,
            [event for part in parts for event in part.events],
            [part.message.received_at for part in parts for _ in part.events],
            # one bridge's messages all alike; were they not, bounding them all is the safe side
            any(part.message.received_is_read for part in parts),
        )
        for device, parts in by_device
    ]
    # Optimistic: should a derivation fail, handle_batch rolls back and redoes each message
    # in its own savepoint, where the failing event's raw row is kept with its derive_error.
    stored = accept_batches(session, batches, transport=transport, optimistic=True)
    for (device, parts), results in zip(by_device, stored, strict=True):
        at = 0
        for part in parts:
            mine, at = results[at : at + len(part.events)], at + len(part.events)
            answers[part.index] = (
                Answer(200, {"results": mine}) if part.batch else _item_answer(mine[0], device.id)
            )
    return [a for a in answers if a is not None]


def handle_batch(
    sessions: sessionmaker[Session],
    messages: Sequence[Message],
    *,
    transport: str,
    max_bytes: int,
) -> list[Answer]:
    """Handle the messages in one transaction; returns the answers, in order, after the commit.

    First all together (one raw insert for every device's events). Should anything but a refusal go
    wrong there (a value the database cannot store, a bug), that transaction is rolled back
    whole and the messages are handled again one by one, each in its own savepoint, so one
    bad message never costs the others their answer. Raises the database's error (nothing
    committed) when the database fails: the caller acknowledges nothing and gets the messages
    again.
    """
    try:
        with sessions.begin() as session:
            return _grouped(session, messages, transport, max_bytes)
    except DATABASE_DOWN:
        raise
    except Exception as exc:
        log.warning(
            "a batch of %d messages failed together (%s); handling each by itself",
            len(messages),
            type(exc).__name__,
        )
    with sessions.begin() as session:
        return [_handle(session, m, transport, max_bytes) for m in messages]
