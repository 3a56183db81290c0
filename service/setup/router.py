"""Setup API (admin): stations, sections, devices, cars."""

from __future__ import annotations

from typing import Any, cast

from fastapi import APIRouter
from sqlalchemy import select

from core.auth import Admin, CurrentReader
from core.database import DbSession, utcnow
from core.models import Car, Device, Station
from service.setup import service
from service.setup.schemas import (
    CarIn,
    CarOut,
    DeviceCreated,
    DeviceIn,
    DeviceOut,
    SectionCreated,
    SectionIn,
    StationIn,
    StationOut,
)
from service.strict_json import StrictJSONRoute

router = APIRouter(tags=["setup"], route_class=StrictJSONRoute)


@router.post("/stations", status_code=201, response_model=StationOut)
def create_station(body: StationIn, session: DbSession, _: Admin) -> Any:
    return service.create_station(session, body)


@router.get("/stations", response_model=list[StationOut])
def list_stations(session: DbSession, _: CurrentReader) -> Any:
    return session.scalars(select(Station).order_by(Station.id)).all()


@router.get("/stations/{station_id}", response_model=StationOut)
def get_station(station_id: str, session: DbSession, _: CurrentReader) -> Any:
    return service.get_or_404(session, Station, station_id, "station")


@router.post("/sections", status_code=201, response_model=SectionCreated)
def create_section(body: SectionIn, session: DbSession, _: Admin) -> dict[str, Any]:
    section = service.create_section(session, body)
    return {
        "id": section.id,
        "from_station": section.from_station,
        "to_station": section.to_station,
        "mode": section.mode,
        "state": section.state,
        "run": None,
    }


@router.post("/devices", status_code=201, response_model=DeviceCreated)
def create_device(body: DeviceIn, session: DbSession, who: Admin) -> Any:
    device, key = service.create_device(session, body, actor=who.name)
    return DeviceCreated(**service.device_view(device, utcnow()), key=key)


@router.get("/devices", response_model=list[DeviceOut])
def list_devices(session: DbSession, _: CurrentReader) -> Any:
    now = utcnow()
    return [
        service.device_view(d, now) for d in session.scalars(select(Device).order_by(Device.id))
    ]


@router.get("/devices/{device_id}", response_model=DeviceOut)
def get_device(device_id: str, session: DbSession, _: CurrentReader) -> Any:
    device = cast(Device, service.get_or_404(session, Device, device_id, "device"))
    return service.device_view(device, utcnow())


@router.post("/cars", status_code=201, response_model=CarOut)
def create_car(body: CarIn, session: DbSession, _: Admin) -> Any:
    return service.create_car(session, body)


@router.get("/cars", response_model=list[CarOut])
def list_cars(session: DbSession, _: CurrentReader) -> Any:
    return session.scalars(select(Car).order_by(Car.id)).all()


@router.get("/cars/{car_id}", response_model=CarOut)
def get_car(car_id: str, session: DbSession, _: CurrentReader) -> Any:
    return service.get_or_404(session, Car, car_id, "car")
