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
MQTT only knows when the bridge *read* a message, which after a backlog is long after the
broker got it: such a time (``received_is_read``) is bounded by the event's own
``occurred_at`` too, so the backlog cannot keep a silent device alive (see ``_received``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from sqlalchemy.orm import Session

from core.models import Device
from ingest.batch_store import not_storable, stored_item, validated
from ingest.handlers import Derivation, derive
from ingest.holding import holding
from ingest.liveness import touched_at_end
from ingest.rows import as_raw, insert_each_that_stores, insert_many, raw_values, write_answers
from ingest.store import answer_now, derive_new

Result = dict[str, Any]
_Entry = tuple[int, int, Any, dict[str, Any]]  # (batch, item, validated event, body)


@dataclass(frozen=True)
class DeviceBatch:
    """One device's items, in the order it sent them; ``received_at`` one per item, or None."""

    device: Device
    items: list[Any]
    received_at: list[datetime | None] | None = field(default=None)
    # The times are when a bridge read the items, not when the broker got them (MQTT).
    received_is_read: bool = False

    def received(self, index: int) -> datetime | None:
        return None if self.received_at is None else self.received_at[index]


def _validate(
    session: Session, b: int, batch: DeviceBatch, results: list[Result | None]
) -> list[_Entry]:
    """The batch's accepted items, by :func:`ingest.batch_store.validated` (the same rules
    item for item); each refusal goes into ``results``. Nothing is written."""
    refusals, accepted = validated(session, batch.device, batch.items)
    for index, refusal in enumerate(refusals):
        if refusal is not None:
            results[index] = refusal
    return [(b, index, event, item) for index, event, item in accepted]


def _received(batch: DeviceBatch, index: int, event: Any, now: datetime) -> datetime:
    """When the item counts as received (its ``received_at``, which liveness counts from).

    Never later than now. A read time may be long after the broker got the message (a bridge
    restarted on a backlog): it is bounded by the event's own time as well, so a device that
    went silent does not look alive until the backlog was read. The device's clock can only
    make that earlier, never later than the read: one set ahead (at most
    ``DEPOT_MAX_CLOCK_SKEW_S``, beyond that the event is refused) counts from the read, one
    set far back makes its device look silent (a person must look), never alive."""
    received = batch.received(index)
    if received is None:
        return now
    if batch.received_is_read:
        received = min(received, event.occurred_at)
    return min(received, now)


def _row(batch: DeviceBatch, index: int, event: Any, body: Result, transport: str) -> Result:
    values = raw_values(batch.device, event, body, answer=answer_now(event), transport=transport)
    values["received_at"] = _received(batch, index, event, values["received_at"])
    return values


def accept_batches(
    session: Session, batches: Sequence[DeviceBatch], *, transport: str, optimistic: bool = False
) -> list[list[Result]]:
    """The ``results`` list of ``accept_batch`` for each batch, all in ``session`` (the caller
    commits). Derivations run in the order of ``batches`` (give them in the order the section
    locks are taken, as the group commit does); each device's items in their own order. As in
    the HTTP group commit, loaded rows are kept for the whole call and the devices' liveness
    rows are written at its end in device order, so that a broker batch and an HTTP group never
    lock section and device rows in a cycle. ``optimistic``: derive without a savepoint per
    event, for a caller that rolls back and handles every message by itself should anything
    but a refusal fail (``transports.envelope.handle_batch``); the raw event of a failing
    derivation is then kept by that second pass."""
    with holding(session), touched_at_end(session):
        return _accept_batches(session, batches, transport=transport, optimistic=optimistic)


def _accept_batches(
    session: Session, batches: Sequence[DeviceBatch], *, transport: str, optimistic: bool
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
    # The optimistic first pass of a broker batch takes no savepoint (a refused value fails it
    # and every message is redone by itself, non-optimistic, where the value's item alone is
    # refused).
    inserted, refused = (
        (insert_many(session, list(rows.values())), {})
        if optimistic
        else insert_each_that_stores(session, list(rows.values()))
    )
    answers: list[Any] = []
    for ident, (b, index, event, body) in first.items():
        device = batches[b].device
        raw_id = inserted.get(ident)
        if ident in refused:
            results[b][index] = not_storable(event.event_id, refused[ident])
            continue
        if raw_id is None:
            results[b][index] = stored_item(session, device, event, body, answers)
            continue
        values = rows[ident]
        if values["result"]:
            derive(Derivation(session, as_raw(raw_id, values), event, device))
            result = values["result"]
        else:
            row = derive_new(session, device, event, raw_id, values, savepoint=not optimistic)
            answers.append(row)
            result = row["result"]
        results[b][index] = {"event_id": event.event_id, "status": "created", "result": result}
    for b, index, event, body in repeats:
        results[b][index] = stored_item(session, batches[b].device, event, body, answers)
    write_answers(session, answers)
    return [[r for r in batch if r is not None] for batch in results]
