"""Storing one validated event: the raw row and its answer, the derivation, retries.

The raw insert decides new or duplicate by the unique ``(device, event_id)`` key; a retry of
the same validated event answers the original result (200, ``"status": "duplicate"``), another
event under a used ``event_id`` is refused (409). A derivation that fails keeps the raw event
(savepoint), except when the database itself failed: then nothing is acknowledged.
"""

from __future__ import annotations

import logging
from typing import Any

from sqlalchemy.exc import InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.orm import Session

from core.errors import Conflict
from core.models import Device
from ingest.checks import check_device_may_send, check_section, parse_event
from ingest.handlers import (
    Derivation,
    check_derivable,
    derivation_failed,
    derive,
    has_handlers,
)
from ingest.liveness import restore_pending, seen, snapshot_pending
from ingest.models import RawEvent, StoredRaw
from ingest.rows import (
    as_raw,
    canonical_sha256,
    event_sha256,
    first_line,
    insert_one,
    raw_values,
    stored,
    stored_many,
    write_answers,
)
from ingest.schemas import section_of

log = logging.getLogger("depot.ingest")


def answer_now(event: Any) -> dict[str, Any] | None:
    """Events no feature derives from answer just "created": stored in the insert itself."""
    if has_handlers(event.kind):
        return None
    return {"event_id": event.event_id, "status": "created"}


def duplicate(
    session: Session, device: Device, event: Any, body: dict[str, Any], answers: list[Any]
) -> tuple[int, dict[str, Any]]:
    """200 with the original answer, marked ``"status": "duplicate"``, for a retry of the same
    event (compared as validated, normalised events); 409 for another event."""
    write_answers(session, answers)  # a retry may follow its original in the same transaction
    return answer_stored(device, event, body, stored(session, device.id, event.event_id))


def answer_stored(
    device: Device, event: Any, body: dict[str, Any], found: tuple[str, dict[str, Any]]
) -> tuple[int, dict[str, Any]]:
    """:func:`duplicate` given the stored (body hash, answer) of the event's id."""
    stored_digest, result = found
    # Rows stored before the hash was normalised carry the hash of the text as received.
    if stored_digest not in (event_sha256(event), canonical_sha256(body)):
        raise Conflict(
            f"event_id {event.event_id!r} was already used by {device.id} for a different event"
        )
    return 200, {**result, "status": "duplicate"}


def answer_if_stored(
    session: Session, device: Device, event: Any, body: dict[str, Any]
) -> tuple[int, dict[str, Any]] | None:
    """The answer to an event whose ``event_id`` the device has used before (200 and the
    original answer for a retry; :class:`Conflict` raised for another event), or None for a
    new one. A snapshot asks before its image is written: a refused upload left a file that
    no event points at (two uploads racing with one id still may; the second is refused)."""
    key = (device.id, event.event_id)
    found = stored_many(session, [key]).get(key)
    return None if found is None else answer_stored(device, event, body, found)


def derive_new(
    session: Session,
    device: Device,
    event: Any,
    raw_id: int,
    values: dict[str, Any],
    *,
    savepoint: bool = True,
) -> dict[str, Any]:
    """Derive a new event; returns its pending answer row (id, result, derive_error).

    ``savepoint=False`` is for a caller that redoes its whole transaction item by item should
    anything fail (the broker batch, like the group commit): the derivation runs without a
    savepoint of its own and any error propagates.
    """
    raw = as_raw(raw_id, values)
    derived = (
        run_derivation(session, raw, event, device)
        if savepoint
        else derive(Derivation(session, raw, event, device))
    )
    result = {"event_id": event.event_id, "status": "created", **derived}
    return {"id": raw_id, "result": result, "derive_error": raw.derive_error}


def store_event(
    session: Session,
    device: Device,
    event: Any,
    body: dict[str, Any],
    *,
    transport: str = "http",
    answers: list[dict[str, Any]] | None = None,
) -> tuple[int, dict[str, Any]]:
    """Store one validated event idempotently; returns (HTTP status, result body).

    201 for a new event (derived results included), 200 with the original result for a retry
    with the same body, 409 (raised) for the same ``event_id`` with a different body. The
    derived answer is written with ``answers`` when given (the caller writes them together,
    before its commit), else at once.
    """
    answer = answer_now(event)
    values = raw_values(device, event, body, answer=answer, transport=transport)
    pending: list[dict[str, Any]] = [] if answers is None else answers
    raw_id = insert_one(session, values)
    if raw_id is None:
        return duplicate(session, device, event, body, pending)
    if answer is not None:
        seen(session, device, values["received_at"], replaying=False)  # liveness only
        return 201, answer
    row = derive_new(session, device, event, raw_id, values)
    pending.append(row)
    if answers is None:
        write_answers(session, pending)
    return 201, row["result"]


def run_derivation(
    session: Session,
    raw: RawEvent | StoredRaw,
    event: Any,
    device: Device,
    *,
    replaying: bool = False,
) -> dict[str, Any]:
    """Derive state from a stored event; a failing derivation never loses the raw event, and
    the failure handler puts the section it names to a person (``derivation_failed``)."""
    derivation = Derivation(session, raw, event, device, replaying)
    if not has_handlers(raw.kind):
        return derive(derivation)  # liveness only: nothing that can fail half-way
    seen = snapshot_pending(session)
    try:
        with session.begin_nested():
            return derive(derivation)
    except (OperationalError, InterfaceError, PendingRollbackError):
        raise  # the database itself failed: nothing is acknowledged, the device retries
    except Exception as exc:
        log.exception("deriving from %s/%s failed", device.id, raw.event_id)
        restore_pending(session, seen)
        raw.derive_error = error = derive_error_text(exc)
        return {"derive_error": error, **derivation_failed(derivation, error)}


def derive_error_text(exc: Exception) -> str:
    """What a device and the event log are told of a failed derivation: the error's kind and
    its first line (:func:`ingest.rows.first_line`)."""
    return f"{type(exc).__name__}: {first_line(exc)}".rstrip(": ")


def accept_event(
    session: Session, device: Device, payload: Any, *, transport: str = "http"
) -> tuple[int, dict[str, Any]]:
    event = parse_event(payload)
    check_device_may_send(device, event.kind)
    check_section(session, device, section_of(event))
    check_derivable(session, event)
    # Stored exactly as received; the canonical hash makes key order irrelevant for retries.
    return store_event(session, device, event, payload, transport=transport)


def store_validated(
    session: Session, device: Device, event: Any, body: dict[str, Any]
) -> tuple[int, dict[str, Any]]:
    """:func:`store_event` after the section check (which needs the database)."""
    check_section(session, device, section_of(event))
    check_derivable(session, event)
    return store_event(session, device, event, body)
