"""Derivation of the maintenance feature: ``measurement`` events become measurement rows."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from core.models import Car
from ingest.handlers import Derivation
from service.fleet.rules import refuse_implausible, registered, value_problems
from service.fleet.service import is_repeated_test, store_test


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
            "warning": f"car {car_id!r} is not registered; register it with POST /api/v1/cars",
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
