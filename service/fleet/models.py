"""Car measurements, forecasts, and engineers' overrides."""

from __future__ import annotations

from datetime import datetime
from typing import Any

import numpy as np
from sqlalchemy import JSON, Float, ForeignKey, Index, Integer, LargeBinary, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from core.database import Base, UTCDateTime, utcnow
from ingest.models import BigId

# A test's values in the order of its layout's names, as little-endian float64 bytes (numpy
# reads them without parsing; PostgreSQL concatenates a car's tests with string_agg). Read and
# write them with service.fleet.service (measured_values, measurement_row) or encode_readings.
READINGS_DTYPE = "<f8"


def encode_readings(values: Any) -> bytes:
    return bytes(np.asarray(values, dtype=READINGS_DTYPE).tobytes())


def decode_readings(data: bytes) -> list[float]:
    return list(np.frombuffer(data, dtype=READINGS_DTYPE).tolist())


class MeasurementLayout(Base):
    """The parameters measured at a test, in the order its readings are stored (names sorted).

    Cars tested on the same bench share one layout, so the fleet's tests are stored as plain
    float arrays without repeating the names.
    """

    __tablename__ = "measurement_layouts"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    key: Mapped[str] = mapped_column(String(64), unique=True)  # sha256 of the names (lookup)
    names: Mapped[list[str]] = mapped_column(JSON)


class Measurement(Base):
    """One test of a car: every value measured at ``taken_at``, in its layout's order.

    A car has one test at a time (unique, migration 0009): a parameter's value at a time is
    never stored twice, and a test is never silently rewritten (service.fleet.service)."""

    __tablename__ = "measurements"
    __table_args__ = (Index("uq_measurements_car_id_taken_at", "car_id", "taken_at", unique=True),)

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=True)
    car_id: Mapped[str] = mapped_column(ForeignKey("cars.id"))
    taken_at: Mapped[datetime] = mapped_column(UTCDateTime(), index=True)
    layout_id: Mapped[int] = mapped_column(ForeignKey("measurement_layouts.id"))
    readings: Mapped[bytes] = mapped_column(LargeBinary)
    # Set when the test came from a device event; such rows are rebuilt by replay.
    raw_event_id: Mapped[int | None] = mapped_column(BigId, nullable=True, index=True)
    source: Mapped[str] = mapped_column(String(32), default="api")


class Forecast(Base):
    __tablename__ = "forecasts"

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=True)
    car_id: Mapped[str] = mapped_column(ForeignKey("cars.id"), index=True)
    computed_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, index=True)
    status: Mapped[str] = mapped_column(String(32))
    risk: Mapped[float | None] = mapped_column(Float, nullable=True)
    payload: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)


class MaintenanceOverride(Base):
    __tablename__ = "maintenance_overrides"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    car_id: Mapped[str] = mapped_column(ForeignKey("cars.id"), index=True)
    action: Mapped[str] = mapped_column(String(32))
    reason: Mapped[str] = mapped_column(Text)
    actor: Mapped[str] = mapped_column(String(64))
    recorded_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)


class Parameter(Base):
    """A measured parameter with its tolerance band: nominal ± tolerance (in ``unit``)."""

    __tablename__ = "maintenance_parameters"

    name: Mapped[str] = mapped_column(String(64), primary_key=True)
    nominal: Mapped[float] = mapped_column(Float)
    tolerance: Mapped[float] = mapped_column(Float)
    unit: Mapped[str] = mapped_column(String(16), default="")
    description: Mapped[str] = mapped_column(Text, default="")
    # Values outside [plausible_lower, plausible_upper] are refused (service/fleet/rules.py);
    # unset, the range follows from the band.
    plausible_lower: Mapped[float | None] = mapped_column(Float, nullable=True)
    plausible_upper: Mapped[float | None] = mapped_column(Float, nullable=True)
