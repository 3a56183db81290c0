"""Request and response bodies of the setup API."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from core.models import DEVICE_KINDS
from core.schemas import Instant, StrictModel
from identification.rules import RULES
from service.setup.names import DEVICE_ID, IDENTIFIER, NAME_PATTERN, PERSON_NAME, person_name

# One rule (names.py) for the API and for the services the CLI calls.
Identifier = Annotated[
    str, Field(min_length=1, max_length=IDENTIFIER.max_length, pattern=NAME_PATTERN)
]
DeviceIdentifier = Annotated[
    str, Field(min_length=1, max_length=DEVICE_ID.max_length, pattern=NAME_PATTERN)
]
# A person's name: any alphabet, stored in NFC (names.PersonNameRule).
PersonName = Annotated[
    str,
    AfterValidator(person_name),
    Field(
        description="what the person is called (Олена Коваль, Petro-Ivanenko): letters of any"
        " alphabet, digits, single spaces, '-', '.', '_' or apostrophes; stored in NFC",
        json_schema_extra={"minLength": 1, "maxLength": PERSON_NAME.max_length},
    ),
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
    last_seen_at: Instant | None = Field(
        default=None,
        description="when the server last received anything from the device (its receive"
        " time, not the device's clock; kept to within 5 s)",
    )
    stale: bool | None = Field(
        default=None,
        description="nothing received from the device within DEPOT_HEARTBEAT_S (its evidence"
        " counts missing); null once the device is decommissioned",
    )


class DeviceCreated(DeviceOut):
    key: str = Field(description="the device key; shown once, store it on the device")


# The codes a wheel mark can carry: ``zones_per_axle`` bits in the duplicate layout the service
# decodes (identification.md §2); a larger code could never be read, so the car would never be
# identified by its wheels (an independent trial registered 300).
WHEEL_CODES = 2**RULES.zones_per_axle


class CarIn(StrictModel):
    """A car of the fleet register. Its numbers must come as JSON numbers (strict: "7" or
    true is refused, never read as 7 or 1)."""

    id: Identifier
    wheel_code: (
        Annotated[
            int,
            Field(
                strict=True,
                ge=0,
                lt=WHEEL_CODES,
                description=f"the code written on its wheels: 0–{WHEEL_CODES - 1}"
                f" ({RULES.zones_per_axle} mark zones per axle)",
            ),
        ]
        | None
    ) = None
    ir_number: Annotated[int, Field(strict=True, ge=0, le=2**32)] | None = None
    axles: Annotated[int, Field(strict=True, ge=2, le=32)] = 4


class CarOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)
    id: str
    wheel_code: int | None
    ir_number: int | None
    axles: int


class SectionCreated(BaseModel):
    id: str
    from_station: str
    to_station: str
    mode: str
    state: str = Field(description="free until the first train departs")
    run: None = Field(default=None, description="no run holds a new section")


class UserIn(StrictModel):
    name: PersonName
    role: Literal["dispatcher", "engineer"]
    expires_in_days: Annotated[float, Field(gt=0, le=3650)] | None = Field(
        default=None, description="the token stops working after this many days (none: never)"
    )


class TokenRotateIn(StrictModel):
    expires_in_days: Annotated[float, Field(gt=0, le=3650)] | None = None


class UserOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)
    name: str
    role: str
    created_at: Instant
    expires_at: Instant | None
    revoked_at: Instant | None


class UserToken(UserOut):
    token: str = Field(description="the bearer token; shown once, store it now")


class DeviceKey(BaseModel):
    device: str
    key: str = Field(description="the new device key; shown once. The old key stops at once.")


class DeviceDecommissioned(BaseModel):
    device: str
    decommissioned_at: Instant


class CredentialChangeOut(BaseModel):
    model_config = ConfigDict(from_attributes=True)
    id: int
    recorded_at: Instant
    actor: str
    action: str
    subject_kind: str
    subject: str
    detail: str
