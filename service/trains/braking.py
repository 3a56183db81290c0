"""``POST /motion/braking-plan``: the protective section and braking start point
of seed 001 (eq. 6–7) for one train; ``depot braking plan`` answers through the
same :func:`plan`.

The ranges are the domain's (:data:`motion.braking.BRAKING_LIMITS`): a value
outside them is answered 422 problem+json with the domain's message, the same
words the CLI prints.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from core.errors import Unprocessable
from motion import braking

# Strict, as the device protocol and the other people's APIs: true, "20" or 2.5 measurements
# are refused, not read as 1, 20 and 2 (a JSON integer is a number).
Number = Annotated[float, Field(allow_inf_nan=False, strict=True)]
Count = Annotated[int, Field(strict=True)]


class ErrorModelIn(BaseModel):
    """Error bounds entering the protective section (defaults as ``depot braking plan``)."""

    model_config = ConfigDict(extra="forbid")
    delta_s_max_m: Number = Field(3.0, description="largest negative braking-distance error, m")
    p_s: Number = Field(1e-2, description="probability of exceeding delta_s_max_m, (0, 1]")
    delta_l_max_m: Number = Field(
        0.0, description="largest positive range error of one measurement, m"
    )
    p_l: Number = Field(1e-2, description="probability one measurement exceeds delta_l_max_m")
    measurements: Count = Field(1, description="measurements per channel (the smallest is used)")
    channels: Count = Field(1, description="independent channels")
    measurement_time_s: Number = Field(0.0, description="duration of one measurement, s")


class BrakingPlanIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    speed_mps: Number = Field(description="speed, m/s")
    deceleration_mps2: Number = Field(description="braking deceleration, m/s²")
    reaction_time_s: Number = Field(0.0, description="reaction time, s")
    gradient_permille: Number = Field(0.0, description="gradient, ‰, positive uphill")
    errors: ErrorModelIn = Field(default_factory=ErrorModelIn)
    obstacle_at_m: Number | None = Field(None, description="obstacle track coordinate, m")


class BrakingPlanOut(BaseModel):
    speed_mps: float
    deceleration_mps2: float
    reaction_time_s: float
    gradient_permille: float
    braking_distance_m: float = Field(description="S_brake(V), reaction distance included")
    reaction_distance_m: float
    delta_s_max_m: float
    delta_l_max_m: float = Field(description="one measurement's bound + distance run during k")
    protective_section_m: float = Field(description="ΔS_max + ΔL_max")
    brake_at_measured_distance_m: float = Field(description="brake when L_meas falls to this")
    brake_start_coordinate_m: float | None
    range_exceedance: float = Field(description="p_l^(k·channels)")
    collision_probability_bound: float = Field(description="eq. (7)")
    meets_sil4: bool


def plan(body: BrakingPlanIn) -> BrakingPlanOut:
    """The plan, or :class:`Unprocessable` with the domain's message.

    The one builder of the answer: the endpoint and ``depot braking plan``
    (its text and ``--json``) both call it, so they answer alike.
    """
    try:
        result = braking.braking_plan(
            **body.model_dump(exclude={"errors"}),
            errors=braking.ErrorModel(**body.errors.model_dump()),
        )
    except ValueError as exc:
        raise Unprocessable(str(exc)) from exc
    return BrakingPlanOut(**result.as_dict())
