"""Latest known position of each train (derived from ``motion_sample`` events)."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import JSON, String
from sqlalchemy.orm import Mapped, mapped_column

from service.database import Base, UTCDateTime


class TrainPosition(Base):
    __tablename__ = "train_positions"

    train: Mapped[str] = mapped_column(String(32), primary_key=True)
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime())
    state: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    filter_state: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
