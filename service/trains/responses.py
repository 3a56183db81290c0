"""Typed answer of ``GET /trains/{train}/position`` (the filter's state, with units)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from core.schemas import Instant


class UnitEstimateOut(BaseModel):
    """One on-board unit's own estimate of the train (each unit has its own filter)."""

    model_config = ConfigDict(extra="allow")

    device: str
    updated_at: Instant = Field(description="device time of the unit's newest sample applied")
    t: float = Field(description="the unit's own on-board clock of that sample, s")
    position_m: float
    speed_mps: float
    direction: int
    sigma_position_m: float
    sigma_speed_mps: float
    position_known: bool = Field(description="false also when the unit is stale")
    section: str | None
    stale: bool = Field(description="no sample from this unit for longer than DEPOT_HEARTBEAT_S")


class TrainPositionOut(BaseModel):
    # The filter reports more diagnostics than documented here; they pass through.
    model_config = ConfigDict(extra="allow")

    train: str
    updated_at: Instant = Field(description="device time of the newest sample applied")
    t: float = Field(description="the on-board clock of that sample, s")
    position_m: float = Field(description="coordinate along the line, m")
    speed_mps: float = Field(
        description="speed along the line, m/s; a magnitude (no sign) while direction is 0"
    )
    acceleration_mps2: float
    direction: int = Field(
        description="1 forward, -1 backward, 0 standing or not yet known (GNSS speed has no"
        " sign: until a standstill, a known prior or two position fixes show it, no direction"
        " is claimed and the position is given both ways from where the sign was assumed)"
    )
    sigma_position_m: float = Field(description="one standard deviation of the position, m")
    sigma_speed_mps: float
    speed_known: bool = Field(
        description="false when the speed's uncertainty is too large to use (e.g. before the"
        " first GNSS speed of a train first seen while moving): a person must look"
    )
    position_known: bool = Field(
        description="false when the uncertainty is too large to use, or the position is stale"
    )
    age_s: float = Field(
        description="seconds from the newest sample's device time to the server's now"
    )
    stale: bool = Field(
        description="no sample for longer than DEPOT_HEARTBEAT_S: position, speed and section"
        " are then not known (position_known and speed_known false, section null)"
    )
    reader_on: bool
    next_marker_id: str | None
    distance_to_next_marker_m: float | None
    last_marker_id: str | None
    missed_marker_ids: list[str]
    section: str | None = Field(
        description="the section the train is in; null while the position is not known"
    )
    gnss_disagrees: bool = Field(
        description="GNSS speeds jumped by more than any brake gives (a fix lost in a tunnel"
        " reads 0) and are not used: the speed is the accelerometer's, its σ that of dead"
        " reckoning"
    )
    device: str | None = Field(
        description="the on-board unit whose estimate this is (the one that reported last)"
    )
    devices: list[UnitEstimateOut] = Field(
        description="every on-board unit of the train with its own estimate: units run their"
        " own clocks and filters, so a second unit never resets the first"
    )
