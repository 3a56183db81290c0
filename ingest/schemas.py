"""Device event schemas of protocol v1: one pydantic model per kind, discriminated by ``kind``."""

from __future__ import annotations

import math
from datetime import datetime
from typing import Annotated, Any, ClassVar, Literal, get_args

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    TypeAdapter,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from core.models import DEVICE_KINDS
from core.schemas import nul_character
from identification.eot_packet import PACKET_BITS, parse_packet
from motion.samples import SAMPLE_LIMITS, sample_problem

from .field_types import (
    CarId,
    DeviceTime,
    EventId,
    Integer,
    Microseconds,
    SectionId,
    TrainNumber,
)


class EventBase(BaseModel):
    """Fields every device event has. ``senders`` are the device kinds that may send the kind
    (another device gets 403); it is the one place that rule is written."""

    # Strict: a count sent as true or "12" is refused, never read as 1 or 12 (a device that
    # sends the wrong JSON type has a bug its integrator must see).
    model_config = ConfigDict(extra="forbid", strict=True)
    senders: ClassVar[frozenset[str]] = frozenset()

    event_id: EventId
    occurred_at: DeviceTime

    @field_validator("*", mode="after")
    @classmethod
    def _text_without_nul(cls, value: Any) -> Any:
        # PostgreSQL's text cannot hold U+0000: a departure naming train "20\u000041" was
        # stored but could not be derived, and left its section free (an independent trial).
        # Refused here, naming the field, on every transport and per item of a batch.
        if _holds_nul(value):
            raise nul_character()
        return value


def _holds_nul(value: Any) -> bool:
    """Whether a field's value (text, or a list or mapping of texts) holds U+0000. Unlike
    :func:`core.schemas.holds_nul` a list is looked into only when its first item is text or a
    container: device events carry long lists of numbers (pulses, samples) on the hot path."""
    if isinstance(value, str):
        return "\x00" in value
    if isinstance(value, dict):
        return any(_holds_nul(k) or _holds_nul(v) for k, v in value.items())
    if isinstance(value, list | tuple) and value and isinstance(value[0], str | dict | list):
        return any(_holds_nul(item) for item in value)
    return False


class SectionEvent(EventBase):
    section: SectionId


EotUnitAddress = Annotated[Integer, Field(ge=0, le=2**17 - 1)]  # 17 bits on the air


class TrainDeparted(SectionEvent):
    kind: Literal["train_departed"]
    senders = frozenset({"interlocking"})
    train: TrainNumber
    # The end-of-train unit armed on this train, when it carries one (clearance.md, EOT).
    eot_unit: EotUnitAddress | None = None


class TrainArrived(SectionEvent):
    kind: Literal["train_arrived"]
    senders = frozenset({"interlocking"})
    train: TrainNumber


class AxleCount(SectionEvent):
    kind: Literal["axle_count"]
    senders = frozenset({"axle_counter"})
    axles: Annotated[Integer, Field(ge=0, le=10_000)]


class IrId(SectionEvent):
    kind: Literal["ir_id"]
    senders = frozenset({"ir_reader"})
    reads: Annotated[list[Annotated[Integer, Field(ge=0, le=2**32)]], Field(max_length=10_000)]


class IrPulses(SectionEvent):
    kind: Literal["ir_pulses"]
    senders = frozenset({"ir_reader"})
    query_period_us: Annotated[float, Field(gt=0, le=1e7, allow_inf_nan=False)]
    reflection_window_us: Annotated[float, Field(ge=0, le=1e7, allow_inf_nan=False)]
    reply_times_us: Annotated[list[Microseconds], Field(max_length=100_000)]
    query_times_us: Annotated[list[Microseconds], Field(max_length=100_000)] | None = None


def _no_booleans(value: object) -> object:
    """A Manchester sample is the JSON number 0 or 1: ``true`` equals 1 in Python, so the
    ``Literal[0, 1]`` check alone read it as a sample (an independent trial). One pass over
    the types in C (a passage may hold a million samples); the index only when one is wrong."""
    if isinstance(value, list) and bool in set(map(type, value)):
        index = next(i for i, sample in enumerate(value) if isinstance(sample, bool))
        raise PydanticCustomError(
            "sample_type",
            "sample {index} is {found}: a sample is the number 0 or 1",
            {"index": index, "found": "true" if value[index] else "false"},
        )
    return value


class IrManchester(SectionEvent):
    kind: Literal["ir_manchester"]
    senders = frozenset({"ir_reader"})
    samples_per_bit: Annotated[Integer, Field(ge=2, le=1024)]
    samples: Annotated[
        list[Literal[0, 1]], BeforeValidator(_no_booleans), Field(max_length=1_000_000)
    ]


class WheelMarks(SectionEvent):
    kind: Literal["wheel_marks"]
    senders = frozenset({"wheel_mark_reader"})
    direction: Literal[1, 2]
    baseline: Annotated[list[Integer], Field(min_length=5, max_length=10_000)]
    axles: Annotated[
        list[Annotated[list[Integer], Field(min_length=1, max_length=256)]],
        Field(min_length=1, max_length=32),
    ]


class WheelMarksWritten(EventBase):
    kind: Literal["wheel_marks_written"]
    senders = frozenset({"marking_station"})
    car: CarId
    code: Annotated[Integer, Field(ge=0, le=2**32)]
    detections: Annotated[list[Literal["W1", "W2"]], Field(max_length=1000)]


def _finite(values: dict[str, float]) -> dict[str, float]:
    bad = [name for name, value in values.items() if not math.isfinite(value)]
    if bad:
        raise ValueError(f"values must be finite numbers: {', '.join(bad)}")
    return values


# A test's readings by parameter name (bench, on-board diagnostics, API, CSV import).
# A reading is a JSON number (an integer is a number too); "3.1" and true are refused on the
# engineer API as they are on the device protocol, whose models are strict anyway.
MeasuredValues = Annotated[
    dict[Annotated[str, Field(min_length=1, max_length=64)], Annotated[float, Field(strict=True)]],
    Field(min_length=1, max_length=200),
    AfterValidator(_finite),
]


class Measurement(EventBase):
    kind: Literal["measurement"]
    senders = frozenset({"test_bench", "onboard_unit"})
    car: CarId
    values: MeasuredValues


# The motion-sample rules live in the pure motion package, with the filter that applies them:
# the bounds below are read from them (so OpenAPI shows them) and the validator runs them all.
_LIM = SAMPLE_LIMITS


class MotionSample(EventBase):
    kind: Literal["motion_sample"]
    senders = frozenset({"onboard_unit"})
    train: TrainNumber
    t: Annotated[float, Field(allow_inf_nan=False)]
    accel_mps2: Annotated[
        float,
        Field(ge=-_LIM.max_abs_accel_mps2, le=_LIM.max_abs_accel_mps2, allow_inf_nan=False),
    ]
    gnss_speed_mps: (
        Annotated[float, Field(ge=0, lt=_LIM.max_gnss_speed_mps, allow_inf_nan=False)] | None
    ) = None
    gnss_delay_s: (
        Annotated[float, Field(ge=0, le=_LIM.max_gnss_delay_s, allow_inf_nan=False)] | None
    ) = None
    marker_id: Annotated[str, Field(min_length=1, max_length=64)] | None = None
    # Optional GNSS position, used to place a marker the reader missed (depot addition).
    gnss_lat: (
        Annotated[
            float,
            Field(ge=-_LIM.max_abs_lat_deg, le=_LIM.max_abs_lat_deg, allow_inf_nan=False),
        ]
        | None
    ) = None
    gnss_lon: (
        Annotated[
            float,
            Field(ge=-_LIM.max_abs_lon_deg, le=_LIM.max_abs_lon_deg, allow_inf_nan=False),
        ]
        | None
    ) = None

    @model_validator(mode="after")
    def _follows_the_sample_rules(self) -> MotionSample:
        """All of ``motion.samples.sample_problem`` (e.g. lat and lon together); the error
        names the field, so the 422 does too."""
        problem = sample_problem(
            self.t,
            self.accel_mps2,
            self.gnss_speed_mps,
            self.gnss_delay_s,
            self.gnss_lat,
            self.gnss_lon,
        )
        if problem is not None:
            # Raised as a ValidationError located at the field (pydantic-core keeps the
            # location; a plain ValueError here would name the whole event instead).
            field, message = problem
            error = PydanticCustomError("motion_sample_rule", message)
            details = [InitErrorDetails(type=error, loc=(field,), input=getattr(self, field))]
            raise ValidationError.from_exception_data(type(self).__name__, details)
        return self


class EotStatus(SectionEvent):
    """An EOT radio receiver's report of one packet from the unit on a train's last car."""

    kind: Literal["eot_status"]
    senders = frozenset({"eot_receiver"})
    unit_address: EotUnitAddress
    pressure_psig: Annotated[Integer, Field(ge=0, le=127)]
    motion: bool | None = None
    marker_light: bool | None = None
    battery_charge: Annotated[Integer, Field(ge=0, le=127)] | None = None  # raw 7-bit value
    bits: Annotated[str, Field(pattern=rf"^[01]{{{PACKET_BITS}}}$")] | None = None

    @model_validator(mode="after")
    def _packet_agrees(self) -> EotStatus:
        """With the raw packet given, its BCH check must pass and its fields match ours."""
        if self.bits is None:
            return self
        try:
            packet = parse_packet(self.bits)
        except ValueError:
            raise ValueError("bits: the packet fails its frame sync or BCH check") from None
        given = {
            "unit_address": self.unit_address,
            "pressure_psig": self.pressure_psig,
            "motion": self.motion,
            "marker_light": self.marker_light,
            "battery_charge": self.battery_charge,
        }
        wrong = [
            f"{name} {value} (the packet says {getattr(packet, name)})"
            for name, value in given.items()
            if value is not None and value != getattr(packet, name)
        ]
        if wrong:
            raise ValueError("fields disagree with bits: " + "; ".join(wrong))
        return self


class Heartbeat(EventBase):
    kind: Literal["heartbeat"]
    senders = frozenset(DEVICE_KINDS)


DeviceEvent = Annotated[
    TrainDeparted
    | TrainArrived
    | AxleCount
    | IrId
    | IrPulses
    | IrManchester
    | WheelMarks
    | WheelMarksWritten
    | Measurement
    | MotionSample
    | EotStatus
    | Heartbeat,
    Field(discriminator="kind"),
]
EVENT_ADAPTER: TypeAdapter[Any] = TypeAdapter(DeviceEvent)
# A batch's items in one validation pass (one call into pydantic-core instead of one per item).
EVENT_LIST_ADAPTER: TypeAdapter[list[Any]] = TypeAdapter(list[DeviceEvent])


class TailSnapshot(SectionEvent):
    """The event stored for a ``POST /snapshots`` upload (the image itself is a file)."""

    kind: Literal["tail_snapshot"]
    senders = frozenset({"camera"})
    image_sha256: Annotated[str, Field(pattern=r"^[0-9a-f]{64}$")]
    content_type: Literal["image/jpeg", "image/png"]
    width: int
    height: int
    size_bytes: int


def kind_of(model: type[EventBase]) -> str:
    """The ``kind`` literal of an event model."""
    (kind,) = get_args(model.model_fields["kind"].annotation)
    return str(kind)


# Every kind `POST /events` accepts, derived from the union above; `tail_snapshot` comes with
# an image through `POST /snapshots` instead.
EVENT_MODELS: tuple[type[EventBase], ...] = get_args(get_args(DeviceEvent)[0])
EVENT_KINDS: tuple[str, ...] = tuple(kind_of(model) for model in EVENT_MODELS)
ALL_EVENT_MODELS: tuple[type[EventBase], ...] = (*EVENT_MODELS, TailSnapshot)
# The models whose ``model_dump()`` is a copy of their ``__dict__`` (no nested model, field
# serializer or computed field; ``tests/service/test_service_events.py`` checks every kind):
# the idempotency hash reads them directly (``ingest.rows.event_sha256``).
FLAT_MODELS: frozenset[type[EventBase]] = frozenset(
    m
    for m in ALL_EVENT_MODELS
    if not m.__pydantic_decorators__.field_serializers
    and not m.__pydantic_decorators__.model_serializers
    and not m.__pydantic_computed_fields__
)
MODEL_BY_KIND: dict[str, type[EventBase]] = {kind_of(m): m for m in ALL_EVENT_MODELS}
# Which event kinds each device kind may send, from the models' `senders`.
ALLOWED_KINDS: dict[str, frozenset[str]] = {
    device_kind: frozenset(kind_of(m) for m in ALL_EVENT_MODELS if device_kind in m.senders)
    for device_kind in DEVICE_KINDS
}


def section_of(event: EventBase) -> str | None:
    """The section an event names, or None for a kind without one. (``getattr(event,
    "section", None)`` says the same but costs an AttributeError raised inside pydantic, some
    microseconds per event of a batch.)"""
    return event.section if isinstance(event, SectionEvent) else None


def event_time(event: EventBase) -> datetime:
    return event.occurred_at
