"""Runs through block sections, the evidence attached to them, and the dispatcher audit."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, Boolean, ForeignKey, Integer, String, Text
from sqlalchemy.orm import Mapped, mapped_column

from core.database import Base, UTCDateTime, utcnow
from ingest.models import BigId


class Run(Base):
    """One train's occupation of a block section; its id is the departure event's raw id."""

    __tablename__ = "runs"

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=False)
    section: Mapped[str] = mapped_column(ForeignKey("sections.id"), index=True)
    train: Mapped[str] = mapped_column(String(32))
    from_station: Mapped[str] = mapped_column(String(32))
    to_station: Mapped[str] = mapped_column(String(32))
    departed_at: Mapped[datetime] = mapped_column(UTCDateTime())
    arrived_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    # "running" (in the section), "arrived", or "conflict" (departed into a section that was not
    # cleared, and waiting behind its current run; ``arrived_at`` says whether it arrived).
    status: Mapped[str] = mapped_column(String(16), default="running")
    verdict: Mapped[str | None] = mapped_column(String(16), nullable=True)
    reasons: Mapped[list[str]] = mapped_column(JSON, default=list)
    auto: Mapped[bool] = mapped_column(Boolean, default=True)
    decided_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    evidence: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    # Clear after a sweep train: a sweep run has ``sweep`` and the run it sweeps in
    # ``sweep_of``; that run gets ``cleared_by`` when the sweep run is decided complete.
    sweep: Mapped[bool] = mapped_column(Boolean, default=False)
    sweep_of: Mapped[int | None] = mapped_column(BigId, nullable=True)
    cleared_by: Mapped[int | None] = mapped_column(BigId, nullable=True)
    # The EOT unit address armed on this train (``train_departed.eot_unit``), if any.
    eot_unit: Mapped[int | None] = mapped_column(Integer, nullable=True)
    # When the server received the departure and the arrival: the moments at which each
    # side's devices are judged silent or not (liveness counts receive times, not device time).
    departure_received_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    arrival_received_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    # The train number the arrival reported (``train_arrived.train``): another number than
    # the departure's is evidence every re-decision keeps (doubts.train_contradictions).
    arrival_train: Mapped[str | None] = mapped_column(String(32), nullable=True)
    # Departed into a section that was not cleared: why, in words (kept for every re-decision,
    # which must ask a person). ``status`` is "conflict" while the run waits behind the
    # section's current run, arrived or not.
    conflict: Mapped[str | None] = mapped_column(Text, nullable=True)
    # The raw id of the ``train_arrived`` that closed the run (an arrival that reached depot
    # before its departure is found by that departure: service.arrivals).
    arrival_id: Mapped[int | None] = mapped_column(BigId, nullable=True)


class EvidenceColumns:
    """What every piece of run evidence has: the sending device and where it stands, the
    device's time (which orders the evidence), and the run and side it was attached to.
    The id is the raw event's id (:func:`service.clearance.handlers.evidence_row` fills these)."""

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=False)
    device_id: Mapped[str] = mapped_column(ForeignKey("devices.id"))
    station: Mapped[str] = mapped_column(String(32))
    section: Mapped[str] = mapped_column(String(32), index=True)
    occurred_at: Mapped[datetime] = mapped_column(UTCDateTime())
    run_id: Mapped[int | None] = mapped_column(BigId, nullable=True, index=True)
    side: Mapped[str | None] = mapped_column(String(16), nullable=True)


class EotReport(EvidenceColumns, Base):
    """One ``eot_status`` report of an EOT radio receiver (same id as its event)."""

    __tablename__ = "eot_reports"

    unit_address: Mapped[int] = mapped_column(Integer)
    pressure_psig: Mapped[int] = mapped_column(Integer)
    motion: Mapped[bool | None] = mapped_column(Boolean, nullable=True)
    marker_light: Mapped[bool | None] = mapped_column(Boolean, nullable=True)
    battery_charge: Mapped[int | None] = mapped_column(Integer, nullable=True)
    bits: Mapped[str | None] = mapped_column(String(74), nullable=True)


class CarPassage(EvidenceColumns, Base):
    """One car passing a reader, decoded; derived from a reader event (same id)."""

    __tablename__ = "car_passages"

    kind: Mapped[str] = mapped_column(String(32))
    number: Mapped[int | None] = mapped_column(Integer, nullable=True)
    car_id: Mapped[str | None] = mapped_column(String(32), nullable=True)
    detail: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)


class AxleReading(EvidenceColumns, Base):
    __tablename__ = "axle_readings"

    axles: Mapped[int] = mapped_column(Integer)


class WheelMarking(Base):
    """The outcome of writing wheel marks on a car at a marking station (same id as its event)."""

    __tablename__ = "wheel_markings"

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=False)
    device_id: Mapped[str] = mapped_column(ForeignKey("devices.id"))
    car_id: Mapped[str] = mapped_column(String(32), index=True)
    code: Mapped[int] = mapped_column(Integer)
    occurred_at: Mapped[datetime] = mapped_column(UTCDateTime())
    state: Mapped[str] = mapped_column(String(16))
    written: Mapped[list[bool]] = mapped_column(JSON, default=list)
    faults: Mapped[list[str]] = mapped_column(JSON, default=list)


class AuditRecord(Base):
    """A dispatcher's action on a run: append-only, with the evidence as it stood."""

    __tablename__ = "audit_records"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    run_id: Mapped[int] = mapped_column(BigId, index=True)
    section: Mapped[str] = mapped_column(String(32))
    action: Mapped[str] = mapped_column(String(32))
    reason: Mapped[str] = mapped_column(Text)
    actor: Mapped[str] = mapped_column(String(64))
    actor_role: Mapped[str] = mapped_column(String(16))
    recorded_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    state_before: Mapped[str] = mapped_column(String(32))
    state_after: Mapped[str] = mapped_column(String(32))
    evidence: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
