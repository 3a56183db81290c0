"""Several devices' batches in one transaction, their raw rows in one statement.

The broker transports commit a batch of messages of many devices at once. Through
``accept_batch`` that costs one raw insert per device (40 devices: 40 statements, 40 round
trips); here every device's new events go in with one ``insert_many`` and the derived answers
with one executemany, whatever the number of devices. The rules are those of
``accept_batch`` item for item (each item stands alone: a refused one leaves the others
stored; a repeat is answered as the original; another event under a used id is 409).

A transport may also say when it received each item (``received_at``): JetStream gives the
instant the stream stored a message, so a backlog in the broker does not make a silent device
look alive later than it spoke. Without it an item is received when it is stored (now).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from sqlalchemy.orm import Session

from core.errors import Conflict, Forbidden, Unprocessable
from core.models import Device
from ingest.checks import check_device_may_send, check_section, parse_event
from ingest.handlers import Derivation, check_derivable, derive
from ingest.holding import holding
from ingest.liveness import touched_at_end
from ingest.rows import as_raw, insert_many, raw_values, write_answers
from ingest.store import answer_now, derive_new, duplicate

Result = dict[str, Any]
_Entry = tuple[int, int, Any, dict[str, Any]]  # (batch, item, validated event, body)


@dataclass(frozen=True)
class DeviceBatch:
    """One device's items, in the order it sent them; ``received_at`` one per item, or None."""

    device: Device
    items: list[Any]
    received_at: list[datetime | None] | None = field(default=None)

    def received(self, index: int) -> datetime | None:
        return None if self.received_at is None else self.received_at[index]


def _rejected(event_id: Any, exc: Unprocessable | Conflict | Forbidden) -> Result:
    error: Result = {"status": exc.status, "title": exc.title, "detail": exc.detail}
    if exc.errors:
        error["errors"] = exc.errors
    return {
        "event_id": event_id if isinstance(event_id, str) else None,
        "status": "rejected",
        "error": error,
    }


def _validate(
    session: Session, b: int, batch: DeviceBatch, results: list[Result | None]
) -> list[_Entry]:
    """The batch's accepted items; each refusal goes into ``results``. Nothing is written."""
    accepted: list[_Entry] = []
    sections_ok: set[str | None] = set()
    for index, item in enumerate(batch.items):
        try:
            event = parse_event(item)
            check_device_may_send(batch.device, event.kind)
            section = getattr(event, "section", None)
            if section not in sections_ok:
                check_section(session, batch.device, section)
                sections_ok.add(section)
            check_derivable(session, event)
        except (Unprocessable, Forbidden, Conflict) as exc:
            results[index] = _rejected(
                item.get("event_id") if isinstance(item, dict) else None, exc
            )
            continue
        accepted.append((b, index, event, item))
    return accepted


def _stored_item(
    session: Session, device: Device, event: Any, body: Result, answers: list[Any]
) -> Result:
    try:
        _, result = duplicate(session, device, event, body, answers)
    except Conflict as exc:
        return _rejected(event.event_id, exc)
    return {"event_id": event.event_id, "status": "duplicate", "result": result}


def _row(batch: DeviceBatch, index: int, event: Any, body: Result, transport: str) -> Result:
    values = raw_values(batch.device, event, body, answer=answer_now(event), transport=transport)
    received = batch.received(index)
    if received is not None:
        values["received_at"] = min(received, values["received_at"])  # never in the future
    return values


def accept_batches(
    session: Session, batches: Sequence[DeviceBatch], *, transport: str
) -> list[list[Result]]:
    """The ``results`` list of ``accept_batch`` for each batch, all in ``session`` (the caller
    commits). Derivations run in the order of ``batches`` (give them in the order the section
    locks are taken, as the group commit does); each device's items in their own order. As in
    the HTTP group commit, loaded rows are kept for the whole call and the devices' liveness
    rows are written at its end in device order, so that a broker batch and an HTTP group never
    lock section and device rows in a cycle."""
    with holding(session), touched_at_end(session):
        return _accept_batches(session, batches, transport=transport)


def _accept_batches(
    session: Session, batches: Sequence[DeviceBatch], *, transport: str
) -> list[list[Result]]:
    results: list[list[Result | None]] = [[None] * len(b.items) for b in batches]
    first: dict[tuple[str, str], _Entry] = {}
    repeats: list[_Entry] = []
    for b, batch in enumerate(batches):
        for entry in _validate(session, b, batch, results[b]):
            ident = (batch.device.id, entry[2].event_id)
            if ident in first:
                repeats.append(entry)
            else:
                first[ident] = entry
    rows = {
        ident: _row(batches[b], index, event, body, transport)
        for ident, (b, index, event, body) in first.items()
    }
    inserted = insert_many(session, list(rows.values()))
    answers: list[Any] = []
    for ident, (b, index, event, body) in first.items():
        device = batches[b].device
        raw_id = inserted.get(ident)
        if raw_id is None:
            results[b][index] = _stored_item(session, device, event, body, answers)
            continue
        values = rows[ident]
        if values["result"]:
            derive(Derivation(session, as_raw(raw_id, values), event, device))
            result = values["result"]
        else:
            row = derive_new(session, device, event, raw_id, values)
            answers.append(row)
            result = row["result"]
        results[b][index] = {"event_id": event.event_id, "status": "created", "result": result}
    for b, index, event, body in repeats:
        results[b][index] = _stored_item(session, batches[b].device, event, body, answers)
    write_answers(session, answers)
    return [[r for r in batch if r is not None] for batch in results]
