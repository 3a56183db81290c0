"""Line setup: stations, block sections, devices, cars, people."""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import ForeignKey, Integer, String
from sqlalchemy.orm import Mapped, mapped_column

from core.database import Base, UTCDateTime, utcnow

DEVICE_KINDS = (
    "interlocking",
    "camera",
    "wheel_mark_reader",
    "ir_reader",
    "axle_counter",
    "marking_station",
    "test_bench",
    "onboard_unit",
    "eot_receiver",
)
ROLES = ("dispatcher", "engineer")
SECTION_STATES = (
    "free",
    "occupied",
    "awaiting_confirmation",
    "review",
    "alarm",
    "blocked",
    "awaiting_sweep",
)


class Station(Base):
    __tablename__ = "stations"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)


class Section(Base):
    """A single-track block section between two stations; one train holds it at a time."""

    __tablename__ = "sections"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    from_station: Mapped[str] = mapped_column(ForeignKey("stations.id"))
    to_station: Mapped[str] = mapped_column(ForeignKey("stations.id"))
    mode: Mapped[str] = mapped_column(String(16))
    # Derived from the runs (rebuilt by replay): the section's state and the run holding it.
    state: Mapped[str] = mapped_column(String(32), default="free")
    current_run_id: Mapped[int | None] = mapped_column(Integer, nullable=True)
    state_since: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)


class Device(Base):
    __tablename__ = "devices"

    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    station: Mapped[str] = mapped_column(ForeignKey("stations.id"))
    section: Mapped[str | None] = mapped_column(ForeignKey("sections.id"), nullable=True)
    kind: Mapped[str] = mapped_column(String(32))
    key_hash: Mapped[str] = mapped_column(String(64), unique=True)
    # When the server last received anything from the device (not the device's clock).
    last_seen_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    # Set once: from then on the device's events are refused (401); its history stays.
    decommissioned_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)


class Car(Base):
    __tablename__ = "cars"

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    wheel_code: Mapped[int | None] = mapped_column(Integer, unique=True, nullable=True)
    ir_number: Mapped[int | None] = mapped_column(Integer, unique=True, nullable=True)
    axles: Mapped[int] = mapped_column(Integer, default=4)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)


class User(Base):
    __tablename__ = "users"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    name: Mapped[str] = mapped_column(String(64), unique=True)
    role: Mapped[str] = mapped_column(String(16))
    token_hash: Mapped[str] = mapped_column(String(64), unique=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    # A token past `expires_at`, or of a revoked person, is refused (401).
    expires_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    revoked_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)


class CredentialChange(Base):
    """Append-only audit of credentials: people added, rotated, revoked; device keys rotated,
    devices decommissioned. Secrets are never recorded."""

    __tablename__ = "credential_changes"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    recorded_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    actor: Mapped[str] = mapped_column(String(64))
    action: Mapped[str] = mapped_column(String(32))
    subject_kind: Mapped[str] = mapped_column(String(16))  # "user" | "device"
    subject: Mapped[str] = mapped_column(String(64), index=True)
    detail: Mapped[str] = mapped_column(String(500), default="")
