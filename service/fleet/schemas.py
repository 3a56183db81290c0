"""Request bodies of the maintenance API (responses are built in :mod:`service.fleet.views`)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from core.schemas import StrictModel
from ingest.field_types import DeviceTime
from ingest.schemas import MeasuredValues
from service.fleet.rules import RULES
from service.reasons import Reason

ParameterName = Annotated[
    str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
]
# "fisher" separates serviceable from faulty tests, so it works only when the fleet calibration
# finds faulty tests in the stored history (422 otherwise).
WeightsMethod = Literal["prediction", "inverse_variance", "rayleigh", "equal", "fisher"]
WEIGHTS_METHODS: tuple[str, ...] = ("prediction", "inverse_variance", "rayleigh", "equal", "fisher")


class MeasurementIn(StrictModel):
    taken_at: DeviceTime
    values: MeasuredValues


# No railway quantity comes near this in any unit; beyond it the band arithmetic overflows.
MAX_MAGNITUDE = 1e15


PLAUSIBLE_LOWER = (
    f"values below are refused (default: nominal − {RULES.plausible_tolerances:g} tolerances,"
    " never below 0 for a duration or resistance unit: s, ms, min, h, Ohm, Ω)"
)
PLAUSIBLE_UPPER = (
    f"values above are refused (default: nominal + {RULES.plausible_tolerances:g} tolerances)"
)


class ParameterIn(StrictModel):
    """A measured parameter and its tolerance band ``nominal ± tolerance``."""

    name: ParameterName
    # Bounded so that the band's edges nominal ± tolerance stay finite numbers.
    nominal: Annotated[float, Field(ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE, allow_inf_nan=False)]
    tolerance: Annotated[float, Field(gt=0, le=MAX_MAGNITUDE, allow_inf_nan=False)]
    unit: Annotated[str, Field(max_length=16)] = ""
    description: Annotated[str, Field(max_length=2000)] = ""
    plausible_lower: (
        Annotated[float, Field(ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE, allow_inf_nan=False)] | None
    ) = Field(default=None, description=PLAUSIBLE_LOWER)
    plausible_upper: (
        Annotated[float, Field(ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE, allow_inf_nan=False)] | None
    ) = Field(default=None, description=PLAUSIBLE_UPPER)


class ForecastRunIn(StrictModel):
    method: WeightsMethod = "prediction"
    horizon: Annotated[int, Field(ge=1, le=365, description="forecast steps")] = 30
    order: Annotated[int, Field(ge=1, le=10, description="AR order of the index")] = 2


class MaintenanceDecisionIn(StrictModel):
    action: Literal["keep_in_service", "withdraw_now"]
    reason: Reason
