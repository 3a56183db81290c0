"""Raw device events: append-only, exactly as received, keyed by (device, event_id)."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import JSON, BigInteger, ForeignKey, Index, Integer, String, Text, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from core.database import Base, UTCDateTime, utcnow

BigId = BigInteger().with_variant(Integer, "sqlite")


class RawEvent(Base):
    __tablename__ = "raw_events"
    __table_args__ = (
        UniqueConstraint("device_id", "event_id"),
        # Serves "latest event of a device received before t" (staleness at decision time).
        Index("ix_raw_events_device_id_received_at", "device_id", "received_at"),
    )

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=True)
    device_id: Mapped[str] = mapped_column(ForeignKey("devices.id"))
    event_id: Mapped[str] = mapped_column(String(64))
    kind: Mapped[str] = mapped_column(String(32), index=True)
    occurred_at: Mapped[datetime] = mapped_column(UTCDateTime())
    received_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow)
    section: Mapped[str | None] = mapped_column(String(32), nullable=True)
    body: Mapped[dict[str, Any]] = mapped_column(JSON)
    body_sha256: Mapped[str] = mapped_column(String(64))
    # What the client was told; written in the same transaction as the row, never changed after.
    result: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    derive_error: Mapped[str | None] = mapped_column(Text, nullable=True)
    # How the event reached the service: "http", "mqtt" or "nats" (docs/DEPLOYMENT.md).
    transport: Mapped[str] = mapped_column(String(8), default="http", server_default="http")


@dataclass(slots=True)
class StoredRaw:
    """A raw event just stored, as the derivations see it: the columns of its row, without the
    ORM object (whose attribute events cost a fifth of an axle count's Python). Derivations
    only read it, and may set ``derive_error``; the row itself is written by statements."""

    id: int
    device_id: str
    event_id: str
    kind: str
    occurred_at: datetime
    received_at: datetime
    section: str | None
    body: dict[str, Any]
    body_sha256: str
    result: dict[str, Any]
    derive_error: str | None = None


class Snapshot(Base):
    """A tail-car image and its detection; derived from a ``tail_snapshot`` raw event (same id)."""

    __tablename__ = "snapshots"

    id: Mapped[int] = mapped_column(BigId, primary_key=True, autoincrement=False)
    device_id: Mapped[str] = mapped_column(ForeignKey("devices.id"))
    station: Mapped[str] = mapped_column(String(32))
    section: Mapped[str] = mapped_column(String(32), index=True)
    occurred_at: Mapped[datetime] = mapped_column(UTCDateTime())
    sha256: Mapped[str] = mapped_column(String(64))
    content_type: Mapped[str] = mapped_column(String(32))
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)
    size_bytes: Mapped[int] = mapped_column(Integer)
    verdict: Mapped[str | None] = mapped_column(String(16), nullable=True)
    score: Mapped[float | None] = mapped_column(nullable=True)
    detection: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    run_id: Mapped[int | None] = mapped_column(BigId, nullable=True, index=True)
    side: Mapped[str | None] = mapped_column(String(16), nullable=True)
