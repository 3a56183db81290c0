"""The group commit's unit: several validated events, of several devices, in one transaction."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from core.errors import DepotError
from core.models import Device
from ingest.checks import check_section
from ingest.handlers import (
    Derivation,
    can_foresee,
    check_derivable,
    derive,
    foreseen_answer,
    lock_section,
)
from ingest.holding import holding
from ingest.liveness import seen, touched_at_end
from ingest.rows import as_raw, insert_many, raw_values, stored_many, write_answers
from ingest.schemas import section_of
from ingest.store import answer_now, answer_stored, duplicate


def _lock_order(item: tuple[Device, Any, dict[str, Any]]) -> tuple[str, str]:
    return (section_of(item[1]) or "", item[0].id)


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
    with holding(session), touched_at_end(session):
        return _store_group(session, items)


def _store_group(
    session: Session, items: list[tuple[Device, Any, dict[str, Any]]]
) -> list[tuple[int, dict[str, Any]] | BaseException]:
    outcomes: list[tuple[int, dict[str, Any]] | BaseException | None] = [None] * len(items)
    order = sorted(range(len(items)), key=lambda i: _lock_order(items[i]))
    for index in order:
        device, event, _ = items[index]
        try:
            check_section(session, device, section_of(event))
            check_derivable(session, event)
        except DepotError as exc:
            outcomes[index] = exc
    valid = [i for i in order if outcomes[i] is None]
    foreseen = _foresee(session, items, valid)
    rows: dict[tuple[str, str], dict[str, Any]] = {}
    for index in valid:
        device, event, body = items[index]
        answer = answer_now(event) or foreseen.get(index)
        rows.setdefault((device.id, event.event_id), raw_values(device, event, body, answer=answer))
    inserted = insert_many(session, list(rows.values()))
    # Stored before this group (retries): looked up together, in one query.
    before = stored_many(session, [key for key in rows if key not in inserted])
    answers: list[dict[str, Any]] = []
    for index in valid:
        device, event, body = items[index]
        raw_id = inserted.pop((device.id, event.event_id), None)
        if raw_id is None:  # stored before, or twice in this group
            found = before.get((device.id, event.event_id))
            try:
                outcomes[index] = (
                    duplicate(session, device, event, body, answers)
                    if found is None
                    else answer_stored(device, event, body, found)
                )
            except DepotError as exc:
                outcomes[index] = exc
            continue
        values = rows[(device.id, event.event_id)]
        if values["result"] and index not in foreseen:  # answered in the insert: liveness only
            seen(session, device, values["received_at"], replaying=False)
            outcomes[index] = (201, values["result"])
            continue
        derived = derive(Derivation(session, as_raw(raw_id, values), event, device))
        result = {"event_id": event.event_id, "status": "created", **derived}
        if result != values["result"]:  # not foreseen, or foreseen otherwise: written again
            answers.append({"id": raw_id, "result": result, "derive_error": None})
        outcomes[index] = (201, result)
    write_answers(session, answers)
    return [o for o in outcomes if o is not None]


def _foresee(
    session: Session, items: list[tuple[Device, Any, dict[str, Any]]], valid: list[int]
) -> dict[int, dict[str, Any]]:
    """The foreseen answers of the group's events (``ingest.handlers.foreseen_answer``), by
    item. When any can be foreseen, every section of the group is locked first, in the
    group's lock order: a lock taken now for one event and later, during derivation, for
    another would break the order two workers' groups take them in."""
    if not any(can_foresee(items[i][1].kind) for i in valid):
        return {}
    for index in valid:
        section = section_of(items[index][1])
        if section is not None:
            lock_section(session, section)
    foreseen = {}
    for index in valid:
        device, event, _ = items[index]
        answer = foreseen_answer(session, device, event)  # None for kinds without a foresight
        if answer is not None:
            foreseen[index] = answer
    return foreseen
