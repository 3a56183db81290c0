"""The device protocol without HTTP: one broker message in, one answer out.

A message is what ``POST /events`` takes as its body (one event or ``{"events": [...]}``), a
device id (from the topic or subject) and the device key (from a user property or header).
The answer is the HTTP answer's body plus ``http_status``. Messages are handled in batches,
each in its own savepoint of one transaction, so the broker can be acknowledged for every
message of the batch after one commit, and one bad message never disturbs the others.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from sqlalchemy import select
from sqlalchemy.exc import DataError, InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.orm import Session, sessionmaker

from core.auth import hash_secret
from core.errors import (
    DepotError,
    PayloadTooLarge,
    Unauthorized,
    Unprocessable,
)
from core.models import Device
from ingest import service
from ingest.batches import batch_events

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
    try:
        return json.loads(data)
    except RecursionError:
        raise Unprocessable("the JSON is nested too deeply") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise Unprocessable(
            f"the payload is not valid JSON ({exc})",
            errors=[{"loc": ["body"], "msg": "invalid JSON"}],
        ) from None


def authenticate(session: Session, message: Message, known: dict[str, Device]) -> Device:
    """The registered device whose key came with the message and whose id names the topic."""
    if not message.key:
        raise Unauthorized("the device key is missing; send it as 'device-key' / Depot-Device-Key")
    device = known.get(message.key)
    if device is None:
        device = session.scalar(select(Device).where(Device.key_hash == hash_secret(message.key)))
    if device is None or device.id != message.device_id:
        raise Unauthorized(
            f"the key is not that of a registered device {message.device_id!r}; "
            "register the device to get a key, and publish under its own id"
        )
    known[message.key] = device
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


def _handle(
    session: Session,
    message: Message,
    transport: str,
    max_bytes: int,
    known: dict[str, Device],
) -> Answer:
    payload: Any = None
    try:
        with session.begin_nested():
            device = authenticate(session, message, known)
            payload = decode(message.payload, max_bytes)
            status, body = accept(session, device, payload, transport)
        return Answer(status, body)
    except DepotError as exc:
        event_id = payload.get("event_id") if isinstance(payload, dict) else None
        return Answer(exc.status, _problem(exc, event_id))
    except DataError:  # a NUL character or an out-of-range number, as in the HTTP app
        return Answer(422, _problem(Unprocessable("a value cannot be stored or looked up")))
    except DATABASE_DOWN:
        raise
    except Exception as exc:
        log.exception("message from %s failed", message.device_id)
        failure = InternalError(f"the message could not be handled ({type(exc).__name__})")
        return Answer(500, _problem(failure), retry=True)


def handle_batch(
    sessions: sessionmaker[Session],
    messages: Sequence[Message],
    *,
    transport: str,
    max_bytes: int,
) -> list[Answer]:
    """Handle the messages in order in one transaction; returns after the commit.

    Raises the database's error (nothing committed) when the database fails: the caller
    acknowledges nothing and gets the messages again.
    """
    known: dict[str, Device] = {}
    with sessions.begin() as session:
        return [_handle(session, m, transport, max_bytes, known) for m in messages]
