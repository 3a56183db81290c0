"""Track markers and train positions."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field


class MarkerIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    id: Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")]
    track_m: Annotated[float, Field(ge=0, le=5_000_000, allow_inf_nan=False)]
    section: Annotated[str, Field(min_length=1, max_length=32)] | None = None
    lat: Annotated[float, Field(ge=-90, le=90)] | None = None
    lon: Annotated[float, Field(ge=-180, le=180)] | None = None


class MarkerOut(MarkerIn):
    model_config = ConfigDict(from_attributes=True)
