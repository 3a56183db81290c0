"""Setup operations. Services flush; the request (or CLI command) owns the transaction."""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime
from typing import Any

from sqlalchemy import or_, select
from sqlalchemy.orm import Session

from core.auth import hash_secret, new_secret
from core.errors import Conflict, NotFound, Unprocessable
from core.models import Car, Device, Section, Station
from ingest.liveness import is_stale
from service.setup.credentials import add_user, record_change
from service.setup.schemas import CarIn, DeviceIn, SectionIn, StationIn


def _ensure_new(session: Session, model: type, ident: str, what: str) -> None:
    if session.get(model, ident) is not None:
        raise Conflict(f"{what} {ident!r} already exists")


def _require(session: Session, model: type, ident: str, what: str) -> object:
    found = session.get(model, ident)
    if found is None:
        raise NotFound(f"{what} {ident!r} does not exist")
    return found


def create_station(session: Session, data: StationIn) -> Station:
    _ensure_new(session, Station, data.id, "station")
    station = Station(id=data.id, name=data.name)
    session.add(station)
    session.flush()
    return station


def create_section(session: Session, data: SectionIn) -> Section:
    _ensure_new(session, Section, data.id, "section")
    for ident in (data.from_station, data.to_station):
        if session.get(Station, ident) is None:
            raise Unprocessable(f"station {ident!r} does not exist; create it first")
    section = Section(
        id=data.id, from_station=data.from_station, to_station=data.to_station, mode=data.mode
    )
    section.state = "free"
    session.add(section)
    session.flush()
    return section


def create_device(session: Session, data: DeviceIn, *, actor: str) -> tuple[Device, str]:
    """Register a device; returns it and its key (shown once). The issued key is audited."""
    _ensure_new(session, Device, data.id, "device")
    if session.get(Station, data.station) is None:
        raise Unprocessable(f"station {data.station!r} does not exist; create it first")
    if data.section is not None:
        section = session.get(Section, data.section)
        if section is None:
            raise Unprocessable(f"section {data.section!r} does not exist; create it first")
        if data.station not in (section.from_station, section.to_station):
            raise Unprocessable(
                f"section {section.id!r} joins {section.from_station} and {section.to_station},"
                f" not station {data.station!r}"
            )
    key = new_secret()
    device = Device(
        id=data.id,
        station=data.station,
        section=data.section,
        kind=data.kind,
        key_hash=hash_secret(key),
    )
    session.add(device)
    where = f"station {data.station}" + (f", section {data.section}" if data.section else "")
    record_change(session, actor, "device_registered", "device", data.id, f"{data.kind} at {where}")
    session.flush()
    return device, key


# What the features do once a car exists (e.g. derive the measurements that waited for it);
# filled by ``service.features.install``, so that setup need not know the features.
CAR_REGISTERED: list[Callable[[Session, str], object]] = []


def create_car(session: Session, data: CarIn) -> Car:
    """Register a car; then every ``CAR_REGISTERED`` hook runs in the same transaction."""
    _ensure_new(session, Car, data.id, "car")
    for column, value in (("wheel_code", data.wheel_code), ("ir_number", data.ir_number)):
        if value is not None and session.scalar(
            select(Car.id).where(getattr(Car, column) == value)
        ):
            raise Conflict(f"another car already has {column} {value}")
    car = Car(id=data.id, wheel_code=data.wheel_code, ir_number=data.ir_number, axles=data.axles)
    session.add(car)
    session.flush()
    for hook in CAR_REGISTERED:
        hook(session, car.id)
    return car


def create_user(session: Session, name: str, role: str) -> str:
    """Create a person with a role; returns the token, which is stored only hashed."""
    return add_user(session, name, role, actor="admin")[1]


def get_or_404(session: Session, model: type, ident: str, what: str) -> object:
    return _require(session, model, ident, what)


def section_devices(session: Session, section: Section, station: str) -> list[Device]:
    """Devices serving one end of a section: its own, plus station-wide ones (interlocking)."""
    return list(
        session.scalars(
            select(Device)
            .where(Device.station == station)
            .where(or_(Device.section == section.id, Device.section.is_(None)))
            .order_by(Device.id)
        )
    )


def device_view(device: Device, now: datetime) -> dict[str, Any]:
    """A device as the API shows it; ``stale`` by the one heartbeat rule at server time ``now``
    (``ingest.liveness.is_stale``: null once decommissioned)."""
    return {
        "id": device.id,
        "station": device.station,
        "section": device.section,
        "kind": device.kind,
        "last_seen_at": device.last_seen_at,
        "stale": is_stale(device, now),
    }
