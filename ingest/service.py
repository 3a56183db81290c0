"""Idempotent storage of device events: validate, store raw, derive, report.

The public entry points, for HTTP and for the other transports (MQTT, NATS bridges):

``ingest_events(session_or_factory, device, payloads, *, transport="http")``
    Store and derive a list of raw event payloads (dicts as received) of one authenticated
    ``device``; returns one result per payload, in order, shaped like the batch answer of
    ``POST /events``: ``{"event_id", "status": "created" | "duplicate" | "rejected",
    "result"?, "error"?}``. With a session the caller commits (and must, before it tells the
    device); with a session factory the function opens a session, commits, and returns only
    after the commit. Each item stands alone, as in a batch.
``accept_event(session, device, payload, *, transport="http")``
    One payload: ``(HTTP status, answer)``; raises the 4xx errors.
``accept_batch(session, device, items, *, transport="http")``
    The batch answer's ``results`` list.
``store_group(session, items)``
    The group commit's unit: several validated events, possibly of several devices, in one
    transaction; one outcome (``(status, answer)`` or the exception) per item.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from datetime import datetime, timedelta
from typing import Any

from pydantic import ValidationError
from sqlalchemy.exc import InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Conflict, DepotError, Forbidden, Unprocessable, validation_errors
from core.models import Device, Section
from core.schemas import format_instant
from core.settings import get_settings
from ingest.handlers import Derivation, check_derivable, derive, has_handlers
from ingest.liveness import restore_pending, snapshot_pending
from ingest.models import RawEvent
from ingest.rows import (
    as_raw,
    canonical_sha256,
    event_sha256,
    insert_many,
    insert_one,
    raw_values,
    stored,
    write_answers,
)
from ingest.schemas import ALLOWED_KINDS, EVENT_ADAPTER, EVENT_KINDS, TailSnapshot

__all__ = [
    "accept_batch",
    "accept_event",
    "canonical_sha256",
    "ingest_events",
    "parse_event",
    "store_event",
    "store_group",
    "store_validated",
    "validate_event",
    "validate_snapshot",
]

log = logging.getLogger("depot.ingest")


def parse_event(payload: Any) -> Any:
    """Validate one event against the schema of its kind; 422 names the offending fields."""
    if not isinstance(payload, dict):
        raise Unprocessable(
            "an event must be a JSON object", errors=[{"loc": ["body"], "msg": "not an object"}]
        )
    kind = payload.get("kind")
    if kind not in EVENT_KINDS:
        raise Unprocessable(
            f"unknown event kind {kind!r}; expected one of {', '.join(EVENT_KINDS)}",
            errors=[{"loc": ["body", "kind"], "msg": "unknown event kind"}],
        )
    try:
        event = EVENT_ADAPTER.validate_python(payload)
    except ValidationError as exc:
        errors = validation_errors(list(exc.errors()))
        for error in errors:
            # The discriminator adds the kind as the first location step; the field is what matters.
            if len(error["loc"]) > 1 and error["loc"][0] == kind:
                error["loc"] = error["loc"][1:]
            error["loc"] = ["body", *error["loc"]]
        fields = ", ".join(".".join(e["loc"][1:]) for e in errors[:5])
        raise Unprocessable(f"invalid {kind} event: {fields}", errors=errors) from None
    check_clock(event, utcnow())
    return event


def check_clock(event: Any, now: datetime) -> None:
    """Refuse an event from a device clock running ahead of the server's by more than
    ``DEPOT_MAX_CLOCK_SKEW_S``: a clock set to 2030 would otherwise keep its device "alive"
    for years and put evidence into runs that have not happened yet."""
    skew = get_settings().max_clock_skew_s
    if event.occurred_at > now + timedelta(seconds=skew):
        ahead = (event.occurred_at - now).total_seconds()
        raise Unprocessable(
            f"occurred_at {format_instant(event.occurred_at)} is {ahead:.0f} s ahead of the"
            f" server's clock ({format_instant(now.replace(microsecond=0))}); at most {skew:g} s"
            " is allowed: set the device's clock (NTP) and send the event again",
            errors=[{"loc": ["body", "occurred_at"], "msg": "ahead of the server's clock"}],
        )


def check_device_may_send(device: Device, kind: str) -> None:
    if kind not in ALLOWED_KINDS.get(device.kind, frozenset()):
        raise Forbidden(f"a {device.kind} device may not send {kind} events")


def check_section(session: Session, device: Device, section_id: str | None) -> None:
    """The protocol's rule: a device's own section, or one starting/ending at its station."""
    if section_id is None:
        return
    loc = {"loc": ["body", "section"], "msg": "section not served by this device"}
    if device.section is not None:
        if section_id != device.section:
            raise Unprocessable(
                f"device {device.id} serves section {device.section}, not {section_id!r}",
                errors=[loc],
            )
        return
    section = session.get(Section, section_id)
    if section is None or device.station not in (section.from_station, section.to_station):
        raise Unprocessable(
            f"section {section_id!r} does not start or end at station {device.station}",
            errors=[loc],
        )


def _answer_now(event: Any) -> dict[str, Any] | None:
    """Events no feature derives from answer just "created": stored in the insert itself."""
    if has_handlers(event.kind):
        return None
    return {"event_id": event.event_id, "status": "created"}


def _duplicate(
    session: Session, device: Device, event: Any, body: dict[str, Any], answers: list[Any]
) -> tuple[int, dict[str, Any]]:
    """200 with the original answer, marked ``"status": "duplicate"``, for a retry of the same
    event (compared as validated, normalised events); 409 for another event."""
    write_answers(session, answers)  # a retry may follow its original in the same transaction
    stored_digest, result = stored(session, device.id, event.event_id)
    # Rows stored before the hash was normalised carry the hash of the text as received.
    if stored_digest not in (event_sha256(event), canonical_sha256(body)):
        raise Conflict(
            f"event_id {event.event_id!r} was already used by {device.id} for a different event"
        )
    return 200, {**result, "status": "duplicate"}


def _derive_new(
    session: Session, device: Device, event: Any, raw_id: int, values: dict[str, Any]
) -> dict[str, Any]:
    """Derive a new event; returns its pending answer row (id, result, derive_error)."""
    raw = as_raw(raw_id, values)
    derived = run_derivation(session, raw, event, device)
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
    answer = _answer_now(event)
    values = raw_values(device, event, body, answer=answer, transport=transport)
    pending: list[dict[str, Any]] = [] if answers is None else answers
    raw_id = insert_one(session, values)
    if raw_id is None:
        return _duplicate(session, device, event, body, pending)
    if answer is not None:
        derive(Derivation(session, as_raw(raw_id, values), event, device))
        return 201, answer
    row = _derive_new(session, device, event, raw_id, values)
    pending.append(row)
    if answers is None:
        write_answers(session, pending)
    return 201, row["result"]


def run_derivation(
    session: Session, raw: RawEvent, event: Any, device: Device, *, replaying: bool = False
) -> dict[str, Any]:
    """Derive state from a stored event; a failing derivation never loses the raw event."""
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
        raw.derive_error = f"{type(exc).__name__}: {exc}"
        return {"derive_error": raw.derive_error}


def accept_event(
    session: Session, device: Device, payload: Any, *, transport: str = "http"
) -> tuple[int, dict[str, Any]]:
    event = parse_event(payload)
    check_device_may_send(device, event.kind)
    check_section(session, device, getattr(event, "section", None))
    check_derivable(session, event)
    # Stored exactly as received; the canonical hash makes key order irrelevant for retries.
    return store_event(session, device, event, payload, transport=transport)


def validate_event(device: Device, payload: Any) -> Any:
    """The checks that need no database: schema and the device kind's permission."""
    event = parse_event(payload)
    check_device_may_send(device, event.kind)
    return event


def store_validated(
    session: Session, device: Device, event: Any, body: dict[str, Any]
) -> tuple[int, dict[str, Any]]:
    """:func:`store_event` after the section check (which needs the database)."""
    check_section(session, device, getattr(event, "section", None))
    check_derivable(session, event)
    return store_event(session, device, event, body)


def _lock_order(item: tuple[Device, Any, dict[str, Any]]) -> tuple[str, str]:
    return (getattr(item[1], "section", None) or "", item[0].id)


def store_group(
    session: Session, items: list[tuple[Device, Any, dict[str, Any]]]
) -> list[tuple[int, dict[str, Any]] | BaseException]:
    """Store validated (device, event, payload) items in one transaction (group commit).

    Optimistic: the raw rows go in with one statement, the derivations run in section, then
    device order (two workers' groups take the section locks in the same order) without a
    savepoint each, the answers go in with one executemany. A refusal (409, 422) is that
    item's outcome and writes nothing. Any other failure propagates: the caller rolls the
    group back and stores every item by itself (:func:`store_validated`, with the savepoint
    that keeps a raw event whose derivation fails). The caller commits.
    """
    outcomes: list[tuple[int, dict[str, Any]] | BaseException | None] = [None] * len(items)
    order = sorted(range(len(items)), key=lambda i: _lock_order(items[i]))
    rows: dict[tuple[str, str], dict[str, Any]] = {}
    for index in order:
        device, event, body = items[index]
        try:
            check_section(session, device, getattr(event, "section", None))
            check_derivable(session, event)
        except DepotError as exc:
            outcomes[index] = exc
            continue
        answer = _answer_now(event)
        rows.setdefault((device.id, event.event_id), raw_values(device, event, body, answer=answer))
    inserted = insert_many(session, list(rows.values()))
    answers: list[dict[str, Any]] = []
    for index in order:
        if outcomes[index] is not None:
            continue
        device, event, body = items[index]
        raw_id = inserted.pop((device.id, event.event_id), None)
        if raw_id is None:  # stored before, or twice in this group
            try:
                outcomes[index] = _duplicate(session, device, event, body, answers)
            except DepotError as exc:
                outcomes[index] = exc
            continue
        values = rows[(device.id, event.event_id)]
        raw = as_raw(raw_id, values)
        derived = derive(Derivation(session, raw, event, device))
        if values["result"]:
            outcomes[index] = (201, values["result"])
            continue
        result = {"event_id": event.event_id, "status": "created", **derived}
        answers.append({"id": raw_id, "result": result, "derive_error": None})
        outcomes[index] = (201, result)
    write_answers(session, answers)
    return [o for o in outcomes if o is not None]


def _rejected(event_id: Any, exc: Unprocessable | Conflict | Forbidden) -> dict[str, Any]:
    error: dict[str, Any] = {"status": exc.status, "title": exc.title, "detail": exc.detail}
    if exc.errors:
        error["errors"] = exc.errors
    return {
        "event_id": event_id if isinstance(event_id, str) else None,
        "status": "rejected",
        "error": error,
    }


def _validated(
    session: Session, device: Device, items: list[Any]
) -> tuple[list[dict[str, Any] | None], list[tuple[int, Any, dict[str, Any]]]]:
    """Validate every item; returns the per-item rejections and the accepted (index, event,
    payload) triples. Nothing is written, so a rejection cannot disturb the others."""
    results: list[dict[str, Any] | None] = [None] * len(items)
    accepted: list[tuple[int, Any, dict[str, Any]]] = []
    sections_ok: set[str | None] = set()
    for index, item in enumerate(items):
        try:
            event = parse_event(item)
            check_device_may_send(device, event.kind)
            section = getattr(event, "section", None)
            if section not in sections_ok:
                check_section(session, device, section)
                sections_ok.add(section)
            check_derivable(session, event)
        except (Unprocessable, Forbidden) as exc:
            results[index] = _rejected(
                item.get("event_id") if isinstance(item, dict) else None, exc
            )
            continue
        accepted.append((index, event, item))
    return results, accepted


def _stored_item(
    session: Session, device: Device, event: Any, body: dict[str, Any], answers: list[Any]
) -> dict[str, Any]:
    """The batch item of an event stored before (a retry, or a reuse of its id)."""
    try:
        _, result = _duplicate(session, device, event, body, answers)
    except Conflict as exc:
        return _rejected(event.event_id, exc)
    return {"event_id": event.event_id, "status": "duplicate", "result": result}


def accept_batch(
    session: Session, device: Device, items: list[Any], *, transport: str = "http"
) -> list[dict[str, Any]]:
    """Each item stands alone: a rejected item leaves the others stored.

    The new events' raw rows go in with one statement (``INSERT … SELECT FROM unnest`` on
    PostgreSQL; the unique key still decides duplicates), then they are derived one by one in
    the batch's order, and the derived answers are written with one executemany.
    """
    results, accepted = _validated(session, device, items)
    first: dict[str, tuple[int, Any, dict[str, Any]]] = {}
    repeats = []
    for entry in accepted:
        if entry[1].event_id in first:
            repeats.append(entry)
        else:
            first[entry[1].event_id] = entry
    rows = {
        event.event_id: raw_values(
            device, event, body, answer=_answer_now(event), transport=transport
        )
        for _, event, body in first.values()
    }
    inserted = insert_many(session, list(rows.values()))
    answers: list[dict[str, Any]] = []
    for index, event, body in first.values():
        raw_id = inserted.get((device.id, event.event_id))
        if raw_id is None:
            results[index] = _stored_item(session, device, event, body, answers)
            continue
        values = rows[event.event_id]
        if values["result"]:
            derive(Derivation(session, as_raw(raw_id, values), event, device))
            result = values["result"]
        else:
            row = _derive_new(session, device, event, raw_id, values)
            answers.append(row)
            result = row["result"]
        results[index] = {"event_id": event.event_id, "status": "created", "result": result}
    for index, event, body in repeats:
        results[index] = _stored_item(session, device, event, body, answers)
    write_answers(session, answers)
    return [r for r in results if r is not None]


def ingest_events(
    target: Session | Callable[[], Session],
    device: Device,
    payloads: list[Any],
    *,
    transport: str = "http",
) -> list[dict[str, Any]]:
    """Store and derive ``payloads`` of ``device`` (see the module docstring); one result per
    payload, in order. With a session factory, returns after the commit."""
    if isinstance(target, Session):
        return accept_batch(target, device, payloads, transport=transport)
    session = target()
    try:
        results = accept_batch(session, device, payloads, transport=transport)
        session.commit()
        return results
    except BaseException:
        session.rollback()
        raise
    finally:
        session.close()


def validate_snapshot(session: Session, device: Device, payload: dict[str, Any]) -> TailSnapshot:
    """Validate the event of an uploaded tail-car image before anything is written."""
    try:
        event = TailSnapshot.model_validate(payload)
    except ValidationError as exc:
        errors = [{**e, "loc": ["body", *e["loc"]]} for e in validation_errors(list(exc.errors()))]
        fields = ", ".join(".".join(e["loc"][1:]) for e in errors[:5])
        raise Unprocessable(f"invalid snapshot: {fields}", errors=errors) from None
    check_device_may_send(device, event.kind)
    check_section(session, device, event.section)
    return event
