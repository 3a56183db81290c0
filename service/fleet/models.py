"""Car measurements, forecasts, and engineers' overrides."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, Float, ForeignKey, Integer, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from ingest.models import BigId
from service.database import Base, UTCDateTime, utcnow


class Measurement(Base):
    __tablename__ = "measurements"

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=True)
    car_id: Mapped[str] = mapped_column(ForeignKey("cars.id"), index=True)
    taken_at: Mapped[datetime] = mapped_column(UTCDateTime(), index=True)
    parameter: Mapped[str] = mapped_column(String(64))
    value: Mapped[float] = mapped_column(Float)
    # Set when the value came from a device event; such rows are rebuilt by replay.
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
