"""Maintenance records: measurements, parameter bands, engineers' overrides.

Services flush; the request (or CLI command) owns the transaction.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session

from core.auth import Principal
from core.errors import Conflict, NotFound, Unprocessable
from core.models import Car
from core.schemas import format_instant
from service.fleet.models import (
    MaintenanceOverride,
    Measurement,
    MeasurementLayout,
    Parameter,
    decode_readings,
    encode_readings,
)
from service.fleet.rules import RULES, plausible_range
from service.fleet.schemas import ParameterIn


def require_car(session: Session, car_id: str) -> Car:
    car = session.get(Car, car_id)
    if car is None:
        raise NotFound(f"car {car_id!r} does not exist; register it with POST /api/v1/cars")
    return car


def layout_key(names: Sequence[str]) -> str:
    return hashlib.sha256(json.dumps(list(names)).encode()).hexdigest()


def layout_id(session: Session, names: Sequence[str], known: dict[str, int] | None = None) -> int:
    """The id of the layout of ``names`` (sorted), created when new; ``known`` caches keys."""
    key = layout_key(names)
    if known is not None and key in known:
        return known[key]
    query = select(MeasurementLayout.id).where(MeasurementLayout.key == key)
    found = session.scalar(query)
    if found is None:
        # Concurrent requests may create the same layout: the unique key keeps one of them.
        dialect = session.get_bind().dialect.name
        make = pg_insert if dialect == "postgresql" else sqlite_insert
        session.execute(
            make(MeasurementLayout)
            .values(key=key, names=list(names))
            .on_conflict_do_nothing(index_elements=["key"])
        )
        found = session.scalars(query).one()
    if known is not None:
        known[key] = found
    return int(found)


def measurement_row(
    session: Session,
    car_id: str,
    taken_at: datetime,
    values: Mapping[str, float],
    *,
    source: str,
    raw_event_id: int | None = None,
    known: dict[str, int] | None = None,
) -> dict[str, Any]:
    """The Measurement row (insert values) of one test: its values in sorted-name order."""
    names = sorted(values)
    return {
        "car_id": car_id,
        "taken_at": taken_at,
        "layout_id": layout_id(session, names, known),
        "readings": encode_readings([values[n] for n in names]),
        "raw_event_id": raw_event_id,
        "source": source,
    }


def insert_ignoring_repeats(session: Session) -> Any:
    """``INSERT … ON CONFLICT (car_id, taken_at) DO NOTHING`` into measurements: the unique
    index (migration 0009) holds one test per car and time, also against a concurrent writer
    that stored it after this transaction looked (PostgreSQL waits for that writer's commit)."""
    dialect = session.get_bind().dialect.name
    make = pg_insert if dialect == "postgresql" else sqlite_insert
    return make(Measurement).on_conflict_do_nothing(index_elements=["car_id", "taken_at"])


def record_measurements(
    session: Session,
    car_id: str,
    taken_at: datetime,
    values: Mapping[str, float],
    *,
    source: str,
    raw_event_id: int | None = None,
) -> int:
    """Store one test of a car (one row); returns the number of values stored: 0 when the car
    already has a test at ``taken_at`` (another transaction stored it after the caller's
    check — :func:`store_test` answers that case by the repeat rule)."""
    row = measurement_row(
        session, car_id, taken_at, values, source=source, raw_event_id=raw_event_id
    )
    # Core insert (the ORM unit of work costs more than the row itself here).
    statement = insert_ignoring_repeats(session).returning(Measurement.id)
    written = session.connection().execute(statement, row).first()
    return len(values) if written is not None else 0


def store_test(
    session: Session,
    car_id: str,
    taken_at: datetime,
    values: dict[str, float],
    *,
    source: str,
    raw_event_id: int | None = None,
) -> int:
    """Store a test unless the car has it already: the number of values stored, 0 for the
    very same test again (idempotent); 409 when a test at ``taken_at`` has other values — also
    when a concurrent request stored it between the check and the insert."""
    if is_repeated_test(session, car_id, taken_at, values):
        return 0
    stored = record_measurements(
        session, car_id, taken_at, values, source=source, raw_event_id=raw_event_id
    )
    if not stored:
        is_repeated_test(session, car_id, taken_at, values)  # the row now seen: 409 or repeat
    return stored


def measured_values(session: Session, test: Measurement) -> dict[str, float]:
    """A stored test's values by parameter name."""
    layout = session.get_one(MeasurementLayout, test.layout_id)
    return dict(zip(layout.names, decode_readings(test.readings), strict=True))


def stored_test(session: Session, car_id: str, taken_at: datetime) -> dict[str, float] | None:
    """The values stored for the car's test at ``taken_at`` (None: no such test yet)."""
    query = (
        select(Measurement)
        .where(Measurement.car_id == car_id, Measurement.taken_at == taken_at)
        .order_by(Measurement.id)
    )
    rows = list(session.scalars(query))
    if not rows:
        return None
    values: dict[str, float] = {}
    for row in rows:  # tests stored at the same time merge, as the forecast reads them
        values.update(measured_values(session, row))
    return values


def is_repeated_test(
    session: Session, car_id: str, taken_at: datetime, values: dict[str, float]
) -> bool:
    """Whether the car already has this very test (True: store nothing again); 409 when it has
    a test at ``taken_at`` with other values — a test is never silently rewritten, whether it
    comes through the API or as a ``measurement`` event."""
    before = stored_test(session, car_id, taken_at)
    if before is None:
        return False
    if before != values:
        listed = ", ".join(f"{name} = {value:g}" for name, value in sorted(before.items()))
        raise Conflict(
            f"car {car_id} already has a test at {format_instant(taken_at)} with other values"
            f" ({listed}); a test is not rewritten: send its correct time, or ask an engineer"
            " to correct the stored test"
        )
    return True


def list_parameters(session: Session) -> list[Parameter]:
    return list(session.scalars(select(Parameter).order_by(Parameter.name)))


def check_plausible_range(data: ParameterIn) -> None:
    """422 unless the plausible range, with the band's defaults for an unset limit, is an
    interval: an inverted one would refuse every value, or hide which limit was meant."""
    lower, upper = plausible_range(Parameter(**data.model_dump()))
    if lower < upper:
        return
    given = [
        f"{name} = {value:g}"
        for name, value in (("plausible_lower", lower), ("plausible_upper", upper))
        if getattr(data, name) is not None
    ]
    loc = "plausible_lower" if data.plausible_lower is not None else "plausible_upper"
    raise Unprocessable(
        f"the plausible range {lower:g}…{upper:g} of {data.name} is empty ({', '.join(given)});"
        " give plausible_lower below plausible_upper (an unset limit is nominal ±"
        f" {RULES.plausible_tolerances:g} tolerances, never below 0 for s or Ω)",
        errors=[{"loc": ["body", loc], "msg": "plausible_lower must be below plausible_upper"}],
    )


def create_parameter(session: Session, data: ParameterIn) -> Parameter:
    check_plausible_range(data)
    if session.get(Parameter, data.name) is not None:
        raise Conflict(
            f"parameter {data.name!r} already exists; change its band with"
            f" PUT /api/v1/maintenance/parameters/{data.name}"
        )
    parameter = Parameter(**data.model_dump())
    session.add(parameter)
    session.flush()
    return parameter


def update_parameter(session: Session, name: str, data: ParameterIn) -> Parameter:
    parameter = session.get(Parameter, name)
    if parameter is None:
        raise NotFound(f"parameter {name!r} does not exist; create it with POST first")
    if data.name != name:
        raise Conflict(f"the body names parameter {data.name!r}, the path {name!r}")
    check_plausible_range(data)
    for field, value in data.model_dump().items():
        setattr(parameter, field, value)
    session.flush()
    return parameter


def record_override(
    session: Session, car_id: str, action: str, reason: str, actor: Principal, at: datetime
) -> MaintenanceOverride:
    """An engineer's decision on a car's forecast; append-only, it is the audit trail."""
    require_car(session, car_id)
    record = MaintenanceOverride(
        car_id=car_id, action=action, reason=reason, actor=actor.name, recorded_at=at
    )
    session.add(record)
    session.flush()
    return record


def overrides_of(session: Session, car_id: str) -> list[MaintenanceOverride]:
    """The car's overrides, newest first."""
    query = (
        select(MaintenanceOverride)
        .where(MaintenanceOverride.car_id == car_id)
        .order_by(MaintenanceOverride.id.desc())
    )
    return list(session.scalars(query))


def latest_overrides(session: Session) -> dict[str, MaintenanceOverride]:
    """Each car's newest override (the one in force)."""
    newest: dict[str, MaintenanceOverride] = {}
    for record in session.scalars(select(MaintenanceOverride).order_by(MaintenanceOverride.id)):
        newest[record.car_id] = record
    return newest
