"""A batch of one device's events: each item stands alone, the raw rows go in together."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Conflict, Forbidden, Unprocessable
from core.models import Device
from ingest.checks import (
    check_clock,
    check_device_may_send,
    check_section,
    latest_allowed,
    parse_event,
    parse_events,
)
from ingest.handlers import VALIDATORS, check_derivable
from ingest.holding import holding
from ingest.liveness import seen, touched_at_end
from ingest.rows import insert_each_that_stores, raw_values, stored_many, write_answers
from ingest.schemas import ALLOWED_KINDS, section_of
from ingest.store import answer_now, answer_stored, derive_new, duplicate


def rejected(event_id: Any, exc: Unprocessable | Conflict | Forbidden) -> dict[str, Any]:
    error: dict[str, Any] = {"status": exc.status, "title": exc.title, "detail": exc.detail}
    if exc.errors:
        error["errors"] = exc.errors
    return {
        "event_id": event_id if isinstance(event_id, str) else None,
        "status": "rejected",
        "error": error,
    }


def not_storable(event_id: str, database_says: str) -> dict[str, Any]:
    """The result of an item whose value the database refused (the others are stored)."""
    return rejected(
        event_id, Unprocessable(f"a value of this event cannot be stored ({database_says})")
    )


def validated(
    session: Session, device: Device, items: list[Any]
) -> tuple[list[dict[str, Any] | None], list[tuple[int, Any, dict[str, Any]]]]:
    """Validate every item; returns the per-item rejections and the accepted (index, event,
    payload) triples. Nothing is written, so a rejection cannot disturb the others."""
    results: list[dict[str, Any] | None] = [None] * len(items)
    accepted: list[tuple[int, Any, dict[str, Any]]] = []
    sections_ok: set[str | None] = set()
    # The kinds this device may send that no feature validates against stored state: for
    # those the two checks below are a set look-up (a call each cost a tenth of the loop).
    plain_kinds = ALLOWED_KINDS.get(device.kind, frozenset()) - {
        k for k, v in VALIDATORS.items() if v
    }
    events = parse_events(items)  # None: some item is invalid, each is then parsed alone
    now = utcnow()
    latest = latest_allowed(now)
    for index, item in enumerate(items):
        try:
            if events is None:
                event = parse_event(item)
            else:
                event = events[index]
                if event.occurred_at > latest:
                    check_clock(event, now)  # refuses it, naming the skew
            plain = event.kind in plain_kinds
            if not plain:
                check_device_may_send(device, event.kind)
            section = section_of(event)
            if section not in sections_ok:
                check_section(session, device, section)
                sections_ok.add(section)
            if not plain:
                check_derivable(session, event)
        except (Unprocessable, Forbidden, Conflict) as exc:
            results[index] = rejected(item.get("event_id") if isinstance(item, dict) else None, exc)
            continue
        accepted.append((index, event, item))
    return results, accepted


def stored_item(
    session: Session,
    device: Device,
    event: Any,
    body: dict[str, Any],
    answers: list[Any],
    found: tuple[str, dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """The batch item of an event stored before (a retry, or a reuse of its id); ``found``:
    its stored (body hash, answer) when already looked up."""
    try:
        if found is None:
            _, result = duplicate(session, device, event, body, answers)
        else:
            _, result = answer_stored(device, event, body, found)
    except Conflict as exc:
        return rejected(event.event_id, exc)
    return {"event_id": event.event_id, "status": "duplicate", "result": result}


def accept_batch(
    session: Session, device: Device, items: list[Any], *, transport: str = "http"
) -> list[dict[str, Any]]:
    """Each item stands alone: a rejected item leaves the others stored.

    The new events' raw rows go in with one statement (``INSERT … SELECT FROM unnest`` on
    PostgreSQL; the unique key still decides duplicates), then they are derived one by one in
    the batch's order, and the derived answers are written with one executemany.
    """
    # Begun here (not by the caller): until the raw insert the batch only reads (the checks),
    # so the insert needs no savepoint of its own (``insert_each_that_stores``).
    own = not session.in_transaction()
    with holding(session), touched_at_end(session):
        return _accept_batch(session, device, items, transport, own)


_Accepted = tuple[int, Any, dict[str, Any]]  # (index in the batch, event, body)


def _first_and_repeats(
    accepted: list[_Accepted],
) -> tuple[dict[str, _Accepted], list[_Accepted]]:
    """The first item of each ``event_id`` (by id), and the items that repeat one."""
    first: dict[str, _Accepted] = {}
    repeats = []
    for entry in accepted:
        if entry[1].event_id in first:
            repeats.append(entry)
        else:
            first[entry[1].event_id] = entry
    return first, repeats


def _accept_batch(
    session: Session, device: Device, items: list[Any], transport: str, own: bool
) -> list[dict[str, Any]]:
    results, accepted = validated(session, device, items)
    first, repeats = _first_and_repeats(accepted)
    # The batch came in one request: one instant of receipt for all its events (and one
    # liveness check for the device instead of one per event).
    received = utcnow()
    rows = {
        event.event_id: raw_values(
            device, event, body, answer=answer_now(event), transport=transport, received=received
        )
        for _, event, body in first.values()
    }
    inserted, refused = insert_each_that_stores(session, list(rows.values()), nothing_written=own)
    device_id = device.id  # an ORM attribute: read once, not a few times per event
    # Stored before this batch (a batch sent again): looked up together, in one query.
    before = stored_many(
        session,
        [
            (device_id, e)
            for e in rows
            if (device_id, e) not in inserted and (device_id, e) not in refused
        ],
    )
    answers: list[dict[str, Any]] = []
    liveness_only = False  # a new event no feature derives from: it only proves the device alive
    for index, event, body in first.values():
        ident = (device_id, event.event_id)
        raw_id = inserted.get(ident)
        if ident in refused:
            results[index] = not_storable(event.event_id, refused[ident])
            continue
        if raw_id is None:
            results[index] = stored_item(session, device, event, body, answers, before.get(ident))
            continue
        values = rows[event.event_id]
        if values["result"]:
            liveness_only = True
            result = values["result"]
        else:
            row = derive_new(session, device, event, raw_id, values)
            answers.append(row)
            result = row["result"]
        results[index] = {"event_id": event.event_id, "status": "created", "result": result}
    if liveness_only:
        # Every event of the batch was received at one instant: the liveness rule applied for
        # one of them is applied for all (``touched_at_end`` touches a device once per instant).
        seen(session, device, received, replaying=False)
    for index, event, body in repeats:
        results[index] = stored_item(session, device, event, body, answers)
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
