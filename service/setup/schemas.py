"""Request and response bodies of the setup API."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from core.models import DEVICE_KINDS
from core.schemas import StrictModel

Identifier = Annotated[
    str, Field(min_length=1, max_length=32, pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
]
DeviceIdentifier = Annotated[
    str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
]
DeviceKind = Literal[DEVICE_KINDS]  # type: ignore[valid-type]


class StationIn(StrictModel):
    id: Identifier
    name: Annotated[str, Field(min_length=1, max_length=200)]


class StationOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)
    id: str
    name: str


class SectionIn(StrictModel):
    id: Identifier
    from_station: Identifier
    to_station: Identifier
    mode: Literal["primary", "auxiliary"] = "primary"

    @model_validator(mode="after")
    def _two_stations(self) -> SectionIn:
        if self.from_station == self.to_station:
            raise ValueError("a block section joins two different stations")
        return self


class DeviceIn(StrictModel):
    id: DeviceIdentifier
    station: Identifier
    section: Identifier | None = None
    kind: DeviceKind


class DeviceOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)
    id: str
    station: str
    section: str | None
    kind: str
    last_seen_at: datetime | None = None
    stale: bool | None = None


class DeviceCreated(DeviceOut):
    key: str = Field(description="the device key; shown once, store it on the device")


class CarIn(StrictModel):
    id: Identifier
    wheel_code: Annotated[int, Field(ge=0, le=2**32)] | None = None
    ir_number: Annotated[int, Field(ge=0, le=2**32)] | None = None
    axles: Annotated[int, Field(ge=2, le=32)] = 4


class CarOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)
    id: str
    wheel_code: int | None
    ir_number: int | None
    axles: int
