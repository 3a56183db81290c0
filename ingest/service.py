"""Idempotent storage of device events: validate, store raw, derive, report."""

from __future__ import annotations

import hashlib
import json
import logging
from typing import Any

from pydantic import ValidationError
from sqlalchemy import select
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.exc import InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.orm import Session

from core.errors import Conflict, Forbidden, Unprocessable, validation_errors
from core.models import Device, Section
from ingest.handlers import Derivation, derive, has_handlers
from ingest.models import RawEvent
from ingest.schemas import ALLOWED_KINDS, EVENT_ADAPTER, EVENT_KINDS, TailSnapshot

log = logging.getLogger("depot.ingest")


def canonical_sha256(body: dict[str, Any]) -> str:
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


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
        return EVENT_ADAPTER.validate_python(payload)
    except ValidationError as exc:
        errors = validation_errors(list(exc.errors()))
        for error in errors:
            # The discriminator adds the kind as the first location step; the field is what matters.
            if len(error["loc"]) > 1 and error["loc"][0] == kind:
                error["loc"] = error["loc"][1:]
            error["loc"] = ["body", *error["loc"]]
        fields = ", ".join(".".join(e["loc"][1:]) for e in errors[:5])
        raise Unprocessable(f"invalid {kind} event: {fields}", errors=errors) from None


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


def _insert_raw(session: Session, values: dict[str, Any]) -> RawEvent | None:
    """Insert unless (device, event_id) exists; returns the new row, or None for a duplicate.

    One statement either way: the unique key, not a read-then-write, decides who stored it,
    so concurrent retries of the same event cannot both win.
    """
    dialect = session.get_bind().dialect.name
    module = postgresql if dialect == "postgresql" else sqlite
    statement = (
        module.insert(RawEvent)
        .values(**values)
        .on_conflict_do_nothing(index_elements=["device_id", "event_id"])
        .returning(RawEvent)
    )
    return session.scalars(statement).one_or_none()


def store_event(
    session: Session, device: Device, event: Any, body: dict[str, Any], *, transport: str = "http"
) -> tuple[int, dict[str, Any]]:
    """Store one validated event idempotently; returns (HTTP status, result body).

    201 for a new event (derived results included), 200 with the original result for a retry
    with the same body, 409 (raised) for the same ``event_id`` with a different body.
    """
    values = _raw_values(device, event, body, transport)
    digest = values["body_sha256"]
    raw = _insert_raw(session, values)
    if raw is None:
        existing = session.scalar(
            select(RawEvent).where(
                RawEvent.device_id == device.id, RawEvent.event_id == event.event_id
            )
        )
        assert existing is not None  # the conflict proves the row exists and is committed
        if existing.body_sha256 != digest:
            raise Conflict(
                f"event_id {event.event_id!r} was already used by {device.id} for a different event"
            )
        return 200, existing.result
    derived = run_derivation(session, raw, event, device)
    if has_handlers(event.kind):
        raw.result = {"event_id": event.event_id, "status": "created", **derived}
    session.flush()
    return 201, raw.result


def run_derivation(
    session: Session, raw: RawEvent, event: Any, device: Device, *, replaying: bool = False
) -> dict[str, Any]:
    """Derive state from a stored event; a failing derivation never loses the raw event."""
    derivation = Derivation(session, raw, event, device, replaying)
    if not has_handlers(raw.kind):
        return derive(derivation)  # liveness only: nothing that can fail half-way
    try:
        with session.begin_nested():
            return derive(derivation)
    except (OperationalError, InterfaceError, PendingRollbackError):
        raise  # the database itself failed: nothing is acknowledged, the device retries
    except Exception as exc:
        log.exception("deriving from %s/%s failed", device.id, raw.event_id)
        raw.derive_error = f"{type(exc).__name__}: {exc}"
        return {"derive_error": raw.derive_error}


def accept_event(
    session: Session, device: Device, payload: Any, *, transport: str = "http"
) -> tuple[int, dict[str, Any]]:
    event = parse_event(payload)
    check_device_may_send(device, event.kind)
    check_section(session, device, getattr(event, "section", None))
    # Stored exactly as received; the canonical hash makes key order irrelevant for retries.
    return store_event(session, device, event, payload, transport=transport)


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
        except (Unprocessable, Forbidden) as exc:
            results[index] = _rejected(
                item.get("event_id") if isinstance(item, dict) else None, exc
            )
            continue
        accepted.append((index, event, item))
    return results, accepted


def _raw_values(
    device: Device, event: Any, body: dict[str, Any], transport: str = "http"
) -> dict[str, Any]:
    # Events no feature derives from answer just "created": store that answer with the row.
    derived = has_handlers(event.kind)
    return {
        "device_id": device.id,
        "event_id": event.event_id,
        "kind": event.kind,
        "occurred_at": event.occurred_at,
        "section": getattr(event, "section", None),
        "body": body,
        "body_sha256": canonical_sha256(body),
        "result": {} if derived else {"event_id": event.event_id, "status": "created"},
        "transport": transport,
    }


def _insert_many(session: Session, rows: list[dict[str, Any]]) -> dict[str, RawEvent]:
    """Insert the rows whose (device, event_id) is new, in one statement; returns them by id."""
    if not rows:
        return {}
    module = postgresql if session.get_bind().dialect.name == "postgresql" else sqlite
    statement = (
        module.insert(RawEvent)
        .on_conflict_do_nothing(index_elements=["device_id", "event_id"])
        .returning(RawEvent)
    )
    return {raw.event_id: raw for raw in session.scalars(statement, rows)}


def accept_batch(
    session: Session, device: Device, items: list[Any], *, transport: str = "http"
) -> list[dict[str, Any]]:
    """Each item stands alone: a rejected item leaves the others stored.

    The new events are inserted with one multi-row statement (the unique key still decides
    duplicates), then derived one by one in the batch's order.
    """
    results, accepted = _validated(session, device, items)
    first: dict[str, tuple[int, Any, dict[str, Any]]] = {}
    repeats = []
    for entry in accepted:
        if entry[1].event_id in first:
            repeats.append(entry)
        else:
            first[entry[1].event_id] = entry
    inserted = _insert_many(
        session, [_raw_values(device, e, b, transport) for _, e, b in first.values()]
    )
    for index, event, body in first.values():
        raw = inserted.get(event.event_id)
        if raw is None:  # stored before: a retry, or a reuse of the id
            try:
                status, result = store_event(session, device, event, body)
            except Conflict as exc:
                results[index] = _rejected(event.event_id, exc)
                continue
        else:
            derived = run_derivation(session, raw, event, device)
            if has_handlers(event.kind):
                raw.result = {"event_id": event.event_id, "status": "created", **derived}
            status, result = 201, raw.result
        results[index] = {
            "event_id": event.event_id,
            "status": "created" if status == 201 else "duplicate",
            "result": result,
        }
    for index, event, body in repeats:
        try:
            status, result = store_event(session, device, event, body)
            results[index] = {"event_id": event.event_id, "status": "duplicate", "result": result}
        except Conflict as exc:
            results[index] = _rejected(event.event_id, exc)
    session.flush()
    return [r for r in results if r is not None]


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
