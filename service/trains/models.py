"""Latest known position of each train (derived from ``motion_sample`` events)."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, Float, String
from sqlalchemy.orm import Mapped, mapped_column

from core.database import Base, UTCDateTime


class TrackMarker(Base):
    """A track marker (balise) with its known track coordinate; optional GNSS position."""

    __tablename__ = "track_markers"

    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    track_m: Mapped[float] = mapped_column(Float)
    section: Mapped[str | None] = mapped_column(String(32), nullable=True)
    lat: Mapped[float | None] = mapped_column(Float, nullable=True)
    lon: Mapped[float | None] = mapped_column(Float, nullable=True)


class TrainPosition(Base):
    __tablename__ = "train_positions"

    train: Mapped[str] = mapped_column(String(32), primary_key=True)
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime())
    state: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    filter_state: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
