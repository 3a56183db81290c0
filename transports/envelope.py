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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from sqlalchemy.exc import DataError, InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.orm import Session, sessionmaker

from core.auth import device_for_key
from core.errors import (
    DepotError,
    PayloadTooLarge,
    Unauthorized,
    Unprocessable,
)
from core.models import Device
from ingest import service
from ingest.batches import batch_events
from ingest.payload import read_json

log = logging.getLogger("depot.transports")

# The database failed: nothing of the batch is committed, so nothing may be acknowledged.
DATABASE_DOWN = (OperationalError, InterfaceError, PendingRollbackError)


class InternalError(DepotError):
    """A failure of the service itself (a bug): nothing stored; the message may come again."""

    status, title = 500, "Internal error"


@dataclass(frozen=True)
class Message:
    """One message from a broker, before anything is known to be right about it."""

    device_id: str
    key: str | None
    payload: bytes


@dataclass(frozen=True)
class Answer:
    """What the device is told; ``retry``: an unexpected failure, nothing stored, try again."""

    status: int
    body: dict[str, Any]
    retry: bool = False

    def to_json(self) -> bytes:
        return json.dumps({**self.body, "http_status": self.status}, default=str).encode()


def _problem(exc: DepotError, event_id: Any = None) -> dict[str, Any]:
    body: dict[str, Any] = {
        "type": "about:blank",
        "title": exc.title,
        "status": exc.status,
        "detail": exc.detail,
    }
    if exc.errors is not None:
        body["errors"] = exc.errors
    if isinstance(event_id, str):
        body["event_id"] = event_id  # so a device can tell which of its messages was refused
    return body


def decode(data: bytes, max_bytes: int) -> Any:
    """The JSON of a payload, as ``POST /events`` reads its body (413 and 422 alike)."""
    if len(data) > max_bytes:
        raise PayloadTooLarge(f"the payload has {len(data)} bytes; the limit is {max_bytes}")
    return read_json(data, what="payload")


def authenticate(session: Session, message: Message) -> Device:
    """The registered device whose key came with the message and whose id names the topic.

    Looked up through the same key cache as ``X-Device-Key`` on HTTP (a detached copy, bounded
    staleness ``DEPOT_DEVICE_KEY_TTL_S``), so a batch costs no look-up per message.
    """
    if not message.key:
        raise Unauthorized("the device key is missing; send it as 'device-key' / Depot-Device-Key")
    device = device_for_key(session, message.key)
    if device is None or device.id != message.device_id:
        raise Unauthorized(
            f"the key is not that of a registered device {message.device_id!r}; "
            "register the device to get a key, and publish under its own id"
        )
    if device.decommissioned_at is not None:
        raise Unauthorized(f"device {device.id} is decommissioned; its events are refused")
    return device


def accept(
    session: Session, device: Device, payload: Any, transport: str
) -> tuple[int, dict[str, Any]]:
    """One payload, single event or batch, through the ingest service as ``POST /events``."""
    events = batch_events(payload)
    if events is not None:
        results = service.accept_batch(session, device, events, transport=transport)
        return 200, {"results": results}
    return service.accept_event(session, device, payload, transport=transport)


def _event_id(payload: Any) -> Any:
    return payload.get("event_id") if isinstance(payload, dict) else None


def _handle(session: Session, message: Message, transport: str, max_bytes: int) -> Answer:
    """One message in its own savepoint: whatever goes wrong with it stays with it."""
    payload: Any = None
    try:
        with session.begin_nested():
            device = authenticate(session, message)
            payload = decode(message.payload, max_bytes)
            status, body = accept(session, device, payload, transport)
        return Answer(status, body)
    except DepotError as exc:
        return Answer(exc.status, _problem(exc, _event_id(payload)))
    except DataError:  # a NUL character or an out-of-range number, as in the HTTP app
        return Answer(422, _problem(Unprocessable("a value cannot be stored or looked up")))
    except DATABASE_DOWN:
        raise
    except Exception as exc:
        log.exception("message from %s failed", message.device_id)
        failure = InternalError(f"the message could not be handled ({type(exc).__name__})")
        return Answer(500, _problem(failure), retry=True)


@dataclass(frozen=True)
class _Part:
    """The events one message brought: where its answer goes, and how it is shaped."""

    index: int
    events: list[Any]
    batch: bool  # sent as {"events": [...]}: answered with "results", as POST /events


def _item_answer(item: dict[str, Any]) -> Answer:
    """The single-event answer of a batch item (what ``accept_event`` answers for it)."""
    if item["status"] == "created":
        return Answer(201, item["result"])
    if item["status"] == "duplicate":
        return Answer(200, item["result"])
    error = item["error"]
    body: dict[str, Any] = {"type": "about:blank", **error}
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
    for index, message in enumerate(messages):
        payload: Any = None
        try:
            device = authenticate(session, message)
            payload = decode(message.payload, max_bytes)
            events = batch_events(payload)
        except DepotError as exc:
            answers[index] = Answer(exc.status, _problem(exc, _event_id(payload)))
            continue
        part = _Part(index, [payload] if events is None else events, events is not None)
        parts.setdefault(device.id, (device, []))[1].append(part)
    order = sorted(parts, key=lambda d: (parts[d][0].section or "", d))
    return {d: parts[d] for d in order}


def _grouped(
    session: Session, messages: Sequence[Message], transport: str, max_bytes: int
) -> list[Answer]:
    """The batch as one ``accept_batch`` per device: a few statements per device, not per
    message. Each event is validated and answered by itself, as in a batch over HTTP."""
    answers: list[Answer | None] = [None] * len(messages)
    for device, parts in _sorted_parts(session, messages, max_bytes, answers).values():
        items = [event for part in parts for event in part.events]
        results = service.accept_batch(session, device, items, transport=transport)
        at = 0
        for part in parts:
            mine, at = results[at : at + len(part.events)], at + len(part.events)
            answers[part.index] = (
                Answer(200, {"results": mine}) if part.batch else _item_answer(mine[0])
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

    First all together (one ``accept_batch`` per device). Should anything but a refusal go
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
