"""Derivation of the maintenance feature: ``measurement`` events become measurement rows."""

from __future__ import annotations

import logging
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Car, Device
from ingest.handlers import Derivation
from ingest.models import RawEvent
from ingest.schemas import EVENT_ADAPTER
from service.fleet.rules import refuse_implausible, registered, value_problems
from service.fleet.service import is_repeated_test, store_test

log = logging.getLogger("depot.fleet")


def measurement_values(session: Session, event: Any) -> None:
    """The validator of ``measurement`` events: every value names a registered parameter and
    is plausible, as for the API and the CSV import; else 422 and nothing is stored. Other
    values for a test the car already has at that time are 409, as on the API."""
    refuse_implausible(registered(session), event.values)
    if session.get(Car, event.car) is not None:
        is_repeated_test(session, event.car, event.occurred_at, event.values)


def measurement(d: Derivation) -> dict[str, Any]:
    car_id = d.event.car
    if d.session.get(Car, car_id) is None:
        # The raw event is kept (replay derives it again once the car is registered).
        return {
            "car": car_id,
            "measurements": 0,
            "warning": (
                f"car {car_id!r} is not registered; register it with POST /api/v1/cars"
                " and this test is stored then"
            ),
        }
    refused = value_problems(registered(d.session), d.event.values)
    if refused:
        # Only on replay of an event stored before the values were checked at the door (or
        # before a parameter's range was narrowed): the raw event is kept, nothing derived.
        return {"car": car_id, "measurements": 0, "refused": refused}
    stored = store_test(
        d.session,
        car_id,
        d.event.occurred_at,
        d.event.values,
        source="event",
        raw_event_id=d.raw.id,
    )
    if not stored:
        return {"car": car_id, "measurements": 0, "note": "this test is already stored"}
    return {"car": car_id, "measurements": stored}


def derive_waiting(session: Session, car_id: str) -> int:
    """Derive the ``measurement`` events stored while ``car_id`` was not registered (their
    raw rows were kept for this), in the order they were received; returns how many tests
    were stored. Called when the car is registered, so the warning's promise holds without a
    replay; what the devices were told (``raw.result``) is never rewritten."""
    waiting = session.scalars(
        select(RawEvent)
        .where(RawEvent.kind == "measurement", RawEvent.body["car"].as_string() == car_id)
        .order_by(RawEvent.id)
    ).all()
    stored = 0
    for raw in waiting:
        device = session.get_one(Device, raw.device_id)
        event = EVENT_ADAPTER.validate_python(raw.body)
        try:
            with session.begin_nested():  # one event that no longer derives leaves the others
                answer = measurement(Derivation(session, raw, event, device, replaying=True))
        except Exception:  # as replay does: the raw row stays, the car is still registered
            log.exception("measurement event %d for car %s did not derive", raw.id, car_id)
            continue
        stored += 1 if answer.get("measurements") else 0
    return stored
