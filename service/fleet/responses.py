"""Typed answers of the maintenance API (the OpenAPI document shows every field).

Fields that the forecast payload adds as the methods grow are allowed through
(``extra="allow"``); the documented fields are the contract.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from core.schemas import Instant
from service.fleet.schemas import PLAUSIBLE_LOWER, PLAUSIBLE_UPPER


class Answer(BaseModel):
    model_config = ConfigDict(extra="allow")


class MeasurementsStored(Answer):
    car: str
    taken_at: Instant
    measurements: int = Field(description="how many parameter values were stored")
    status: Literal["created", "duplicate"] = Field(
        "created", description="duplicate: the same test was stored before (nothing stored now)"
    )


class ParameterOut(Answer):
    name: str
    nominal: float
    tolerance: float
    lower: float = Field(description="nominal − tolerance: the band's lower edge")
    upper: float = Field(description="nominal + tolerance: the band's upper edge")
    unit: str
    description: str | None = None
    plausible_lower: float = Field(
        description=f"{PLAUSIBLE_LOWER} (the engineer's, else the default)"
    )
    plausible_upper: float = Field(
        description=f"{PLAUSIBLE_UPPER} (the engineer's, else the default)"
    )


class CarRisk(Answer):
    car: str
    risk: float | None


class ForecastRunOut(Answer):
    computed_at: Instant
    cars: int
    statuses: dict[str, int]
    calibration: Any = Field(description="how the index band and weights were calibrated")
    highest_risk: list[CarRisk]


class OverrideOut(Answer):
    id: int
    car: str
    action: str
    reason: str
    actor: str
    recorded_at: Instant
    forecast_since: bool = Field(description="a newer forecast exists than this decision")


class ExitStep(Answer):
    step: int
    at: Instant | None


class ForecastStep(Answer):
    step: int
    at: Instant | None
    value: float
    lower: float
    upper: float


class IndexForecast(Answer):
    level: float | None
    steps: list[ForecastStep]


class CarSummary(Answer):
    car: str
    forecast_id: int
    computed_at: Instant
    status: str
    risk: float | None = Field(
        description="the car's failure risk within the horizon: the larger of the index risk"
        " and the K-of-L probability (None: no usable forecast, or a parameter did not vary —"
        " a person must look)"
    )
    recommendation: str = Field(
        description="plan_withdrawal, inspect (a person must look), watch, serviceable or"
        " unknown (not enough history); never less severe than the risk says"
    )
    decision: str
    first_exit: ExitStep | None
    out_of_band_now: bool = Field(
        description="the latest index, or a parameter at the latest test, is already outside"
        " its band (the car ranks before every car inside its band)"
    )
    out_of_tolerance_now: list[str] = Field(
        default_factory=list, description="parameters outside tolerance at the latest test"
    )
    k_of_l_probability: float | None = None
    index_risk: float | None = Field(
        None, description="probability of the index leaving its band within the horizon"
    )
    parameter_risk: float | None = Field(
        None,
        description="the largest probability of one parameter leaving its tolerance band within"
        " the horizon; from 0.5 the car is at least watch",
    )
    probabilities_calibrated: bool | None = Field(
        None,
        description="false: the fleet index band was not calibrated; every probability is a"
        " model estimate, shown clipped away from 0 and 1",
    )
    unvarying: list[str] = Field(
        default_factory=list,
        description="parameters with no variation over their latest tests (sensor may be stuck)",
    )
    reasons: list[str]
    weights: dict[str, float]
    contributions: dict[str, float]
    override: OverrideOut | None


class RankedCar(CarSummary):
    rank: int


class FleetOut(Answer):
    computed_at: Instant | None
    cars: list[RankedCar] = Field(description="cars in service, highest risk first")
    withdrawn: list[CarSummary] = Field(description="cars an engineer withdrew from service")


class IndexPoint(Answer):
    at: Instant | None
    index: float | None


class BandOut(Answer):
    lower: float
    upper: float
    unit: str


class ForecastOut(CarSummary):
    method: str | None
    calibration: Any = Field(description="how the index band and weights were calibrated")
    n_measurements: int
    horizon: int | None
    failure_k: int | None
    index_band: Any
    index_history: list[IndexPoint] = Field(
        description="the latest index points, oldest first (at most the query's limit)"
    )
    index_history_total: int = Field(0, description="the car's tests (the forecast used all)")
    index_history_stored: int = Field(
        0, description="index points the stored forecast keeps (the largest limit that helps)"
    )
    forecast: IndexForecast | None
    parameter_exit_probability: dict[str, Any]
    bands: dict[str, BandOut]
    overrides: list[OverrideOut]
