"""Device event schemas of protocol v1: one pydantic model per kind, discriminated by ``kind``."""

from __future__ import annotations

import math
from datetime import UTC, datetime
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    AwareDatetime,
    BaseModel,
    ConfigDict,
    Field,
    TypeAdapter,
    ValidationError,
    model_validator,
)
from pydantic_core import InitErrorDetails, PydanticCustomError

from motion.samples import SAMPLE_LIMITS, sample_problem

EARLIEST = datetime(2000, 1, 1, tzinfo=UTC)
LATEST = datetime(2100, 1, 1, tzinfo=UTC)


def _plausible(at: datetime) -> datetime:
    # A device clock outside this range is broken; its times would poison every computation.
    if not EARLIEST <= at < LATEST:
        raise ValueError("time must be between 2000-01-01 and 2100-01-01 (check the device clock)")
    return at


DeviceTime = Annotated[AwareDatetime, AfterValidator(_plausible)]
EventId = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[\x21-\x7e]+$")]
SectionId = Annotated[str, Field(min_length=1, max_length=32)]
TrainNumber = Annotated[str, Field(min_length=1, max_length=32)]
CarId = Annotated[str, Field(min_length=1, max_length=32)]
Microseconds = Annotated[float, Field(ge=0, allow_inf_nan=False)]


class EventBase(BaseModel):
    model_config = ConfigDict(extra="forbid")

    event_id: EventId
    occurred_at: DeviceTime


class SectionEvent(EventBase):
    section: SectionId


class TrainDeparted(SectionEvent):
    kind: Literal["train_departed"]
    train: TrainNumber


class TrainArrived(SectionEvent):
    kind: Literal["train_arrived"]
    train: TrainNumber


class AxleCount(SectionEvent):
    kind: Literal["axle_count"]
    axles: Annotated[int, Field(ge=0, le=10_000)]


class IrId(SectionEvent):
    kind: Literal["ir_id"]
    reads: Annotated[list[Annotated[int, Field(ge=0, le=2**32)]], Field(max_length=10_000)]


class IrPulses(SectionEvent):
    kind: Literal["ir_pulses"]
    query_period_us: Annotated[float, Field(gt=0, le=1e7, allow_inf_nan=False)]
    reflection_window_us: Annotated[float, Field(ge=0, le=1e7, allow_inf_nan=False)]
    reply_times_us: Annotated[list[Microseconds], Field(max_length=100_000)]
    query_times_us: Annotated[list[Microseconds], Field(max_length=100_000)] | None = None


class IrManchester(SectionEvent):
    kind: Literal["ir_manchester"]
    samples_per_bit: Annotated[int, Field(ge=2, le=1024)]
    samples: Annotated[list[Literal[0, 1]], Field(max_length=1_000_000)]


class WheelMarks(SectionEvent):
    kind: Literal["wheel_marks"]
    direction: Literal[1, 2]
    baseline: Annotated[list[int], Field(min_length=5, max_length=10_000)]
    axles: Annotated[
        list[Annotated[list[int], Field(min_length=1, max_length=256)]],
        Field(min_length=1, max_length=32),
    ]


class WheelMarksWritten(EventBase):
    kind: Literal["wheel_marks_written"]
    car: CarId
    code: Annotated[int, Field(ge=0, le=2**32)]
    detections: Annotated[list[Literal["W1", "W2"]], Field(max_length=1000)]


def _finite(values: dict[str, float]) -> dict[str, float]:
    bad = [name for name, value in values.items() if not math.isfinite(value)]
    if bad:
        raise ValueError(f"values must be finite numbers: {', '.join(bad)}")
    return values


# A test's readings by parameter name (bench, on-board diagnostics, API, CSV import).
MeasuredValues = Annotated[
    dict[Annotated[str, Field(min_length=1, max_length=64)], float],
    Field(min_length=1, max_length=200),
    AfterValidator(_finite),
]


class Measurement(EventBase):
    kind: Literal["measurement"]
    car: CarId
    values: MeasuredValues


# The motion-sample rules live in the pure motion package, with the filter that applies them:
# the bounds below are read from them (so OpenAPI shows them) and the validator runs them all.
_LIM = SAMPLE_LIMITS


class MotionSample(EventBase):
    kind: Literal["motion_sample"]
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


class Heartbeat(EventBase):
    kind: Literal["heartbeat"]


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
    | Heartbeat,
    Field(discriminator="kind"),
]
EVENT_ADAPTER: TypeAdapter[Any] = TypeAdapter(DeviceEvent)
EVENT_KINDS = (
    "train_departed",
    "train_arrived",
    "axle_count",
    "ir_id",
    "ir_pulses",
    "ir_manchester",
    "wheel_marks",
    "wheel_marks_written",
    "measurement",
    "motion_sample",
    "heartbeat",
)

# Which event kinds each device kind may send (a device posting another kind gets 403).
ALLOWED_KINDS: dict[str, frozenset[str]] = {
    "interlocking": frozenset({"train_departed", "train_arrived", "heartbeat"}),
    "camera": frozenset({"heartbeat", "tail_snapshot"}),
    "wheel_mark_reader": frozenset({"wheel_marks", "heartbeat"}),
    "ir_reader": frozenset({"ir_id", "ir_pulses", "ir_manchester", "heartbeat"}),
    "axle_counter": frozenset({"axle_count", "heartbeat"}),
    "marking_station": frozenset({"wheel_marks_written", "heartbeat"}),
    "test_bench": frozenset({"measurement", "heartbeat"}),
    "onboard_unit": frozenset({"motion_sample", "measurement", "heartbeat"}),
}


class TailSnapshot(SectionEvent):
    """The event stored for a ``POST /snapshots`` upload (the image itself is a file)."""

    kind: Literal["tail_snapshot"]
    image_sha256: Annotated[str, Field(pattern=r"^[0-9a-f]{64}$")]
    content_type: Literal["image/jpeg", "image/png"]
    width: int
    height: int
    size_bytes: int


class EventBatch(BaseModel):
    model_config = ConfigDict(extra="forbid")
    events: Annotated[list[dict[str, Any]], Field(min_length=1, max_length=1000)]


class EventAck(BaseModel):
    event_id: str
    status: Literal["created", "duplicate"]
    model_config = ConfigDict(extra="allow")


class BatchItemResult(BaseModel):
    event_id: str | None
    status: Literal["created", "duplicate", "rejected"]
    error: dict[str, Any] | None = None
    result: dict[str, Any] | None = None


class BatchResult(BaseModel):
    results: list[BatchItemResult]


def event_time(event: EventBase) -> datetime:
    return event.occurred_at
