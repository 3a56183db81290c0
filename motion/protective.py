"""Protective section and braking start point (seed ``001``, eq. 1, 6, 7).

Re-exported by :mod:`motion.braking`; see there for the paper's context.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from .braking_limits import BRAKING_LIMITS, check_range
from .trials import SIL4, exceedance

G = 9.81

# --------------------------------------------------------------------------
# Protective section and braking start point: equations (1), (6), (7)
# --------------------------------------------------------------------------


def braking_distance(
    speed_mps: float,
    deceleration_mps2: float,
    reaction_time_s: float = 0.0,
    gradient_permille: float = 0.0,
) -> float:
    """``S_brake(V) = V·t_r + V²/(2·(b + g·i/1000))``.

    ``gradient_permille`` is positive uphill (helps braking), negative
    downhill.  Raises ``ValueError`` for an input outside
    :data:`~motion.braking_limits.BRAKING_LIMITS`, or if the gradient
    overcomes the brake.
    """
    check_train(speed_mps, deceleration_mps2, reaction_time_s, gradient_permille)
    a = deceleration_mps2 + G * gradient_permille / 1000.0
    if a <= 0:
        raise ValueError(_no_braking(deceleration_mps2, gradient_permille))
    return speed_mps * reaction_time_s + speed_mps**2 / (2 * a)


def check_train(
    speed_mps: float,
    deceleration_mps2: float,
    reaction_time_s: float = 0.0,
    gradient_permille: float = 0.0,
    *,
    moving: bool = False,
) -> None:
    """``ValueError`` naming the first of the train's quantities outside its
    range (``moving``: the speed must be positive)."""
    lim = BRAKING_LIMITS
    check_range("speed", speed_mps, 0.0, lim.max_speed_mps, "m/s", low_open=moving)
    check_range(
        "deceleration", deceleration_mps2, 0.0, lim.max_deceleration_mps2, "m/s²", low_open=True
    )
    check_range("reaction time", reaction_time_s, 0.0, lim.max_reaction_time_s, "s")
    g = lim.max_abs_gradient_permille
    check_range("gradient", gradient_permille, -g, g, "‰")


@dataclass(frozen=True)
class ErrorModel:
    """Error bounds entering the protective section.

    * ``delta_s_max_m`` — largest magnitude of a *negative* braking-distance
      error (computed braking shorter than real); ``p_s`` the probability it
      is exceeded (e.g. from a Monte Carlo study, :func:`p_max_for_trials`).
    * ``delta_l_max_m`` — largest positive range-measurement error of one
      measurement; ``p_l`` the probability one measurement exceeds it.
    * ``measurements`` (k) per channel and ``channels``: the smallest of the
      measurements is used; ``measurement_time_s`` is one measurement's
      duration, so ``ΔL_max`` grows by ``V·k·τ``.
    """

    delta_s_max_m: float = 3.0
    p_s: float = 1e-2
    delta_l_max_m: float = 0.0
    p_l: float = 1e-2
    measurements: int = 1
    channels: int = 1
    measurement_time_s: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a model that would invert the margin or claim certainty."""
        lim = BRAKING_LIMITS
        check_range("ΔS_max", self.delta_s_max_m, 0.0, lim.max_margin_m, "m")
        check_range("ΔL_max", self.delta_l_max_m, 0.0, lim.max_margin_m, "m")
        check_range("p_s", self.p_s, 0.0, 1.0, "", low_open=True)
        check_range("p_l", self.p_l, 0.0, 1.0, "", low_open=True)
        check_range("measurements k", self.measurements, 1, lim.max_measurements, "")
        check_range("channels", self.channels, 1, lim.max_channels, "")
        check_range(
            "measurement time", self.measurement_time_s, 0.0, lim.max_measurement_time_s, "s"
        )
        for name in ("measurements", "channels"):
            if int(getattr(self, name)) != getattr(self, name):
                raise ValueError(f"{name} must be a whole number")


@dataclass(frozen=True)
class BrakingPlan:
    speed_mps: float
    deceleration_mps2: float
    reaction_time_s: float
    gradient_permille: float
    braking_distance_m: float  # S_brake(V), reaction distance included
    reaction_distance_m: float
    delta_s_max_m: float
    delta_l_max_m: float  # one measurement's bound + distance run during k measurements
    protective_section_m: float  # ΔS_max + ΔL_max
    brake_at_measured_distance_m: float  # brake when L_meas falls to this
    brake_start_coordinate_m: float | None  # obstacle coordinate - the above, if given
    range_exceedance: float  # p_l^(k·c)
    collision_probability_bound: float  # eq. (7)
    meets_sil4: bool

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def braking_plan(
    speed_mps: float,
    deceleration_mps2: float,
    *,
    reaction_time_s: float = 0.0,
    gradient_permille: float = 0.0,
    errors: ErrorModel | None = None,
    obstacle_at_m: float | None = None,
) -> BrakingPlan:
    """Braking start point and protective section for a train, eq. (6)–(7).

    Braking must start when the measured distance falls to
    ``S_brake(V) + ΔS_max + ΔL_max``; if ``obstacle_at_m`` (track
    coordinate of the obstacle, train running towards increasing
    coordinate) is given, the start point is also returned as a coordinate.
    """
    em = errors or ErrorModel()
    s = braking_distance(speed_mps, deceleration_mps2, reaction_time_s, gradient_permille)
    if obstacle_at_m is not None:
        c = BRAKING_LIMITS.max_abs_coordinate_m
        check_range("obstacle coordinate", obstacle_at_m, -c, c, "m")
    dl = em.delta_l_max_m + speed_mps * em.measurements * em.measurement_time_s
    prot = em.delta_s_max_m + dl
    brake_at = s + prot
    p_range = exceedance(em.p_l, em.measurements, em.channels) if em.delta_l_max_m > 0 else 1.0
    bound = em.p_s * p_range
    return BrakingPlan(
        speed_mps=speed_mps,
        deceleration_mps2=deceleration_mps2,
        reaction_time_s=reaction_time_s,
        gradient_permille=gradient_permille,
        braking_distance_m=s,
        reaction_distance_m=speed_mps * reaction_time_s,
        delta_s_max_m=em.delta_s_max_m,
        delta_l_max_m=dl,
        protective_section_m=prot,
        brake_at_measured_distance_m=brake_at,
        brake_start_coordinate_m=None if obstacle_at_m is None else obstacle_at_m - brake_at,
        range_exceedance=p_range,
        collision_probability_bound=bound,
        meets_sil4=bound <= SIL4 * (1 + 1e-9),
    )


def max_safe_speed(
    measured_distance_m: float,
    deceleration_mps2: float,
    *,
    reaction_time_s: float = 0.0,
    gradient_permille: float = 0.0,
    errors: ErrorModel | None = None,
) -> float:
    """The highest speed whose braking start point (6) is not beyond
    ``measured_distance_m``: solves ``V·t_r + V²/(2a) + ΔS + ΔL₀ + V·k·τ = L``."""
    em = errors or ErrorModel()
    check_train(0.0, deceleration_mps2, reaction_time_s, gradient_permille)
    c = BRAKING_LIMITS.max_abs_coordinate_m
    check_range("measured distance", measured_distance_m, 0.0, c, "m")
    a = deceleration_mps2 + G * gradient_permille / 1000.0
    if a <= 0:
        raise ValueError(_no_braking(deceleration_mps2, gradient_permille))
    room = measured_distance_m - em.delta_s_max_m - em.delta_l_max_m
    if room <= 0:
        return 0.0
    lin = reaction_time_s + em.measurements * em.measurement_time_s
    # V²/(2a) + lin·V - room = 0
    return float(-lin * a + math.sqrt((lin * a) ** 2 + 2 * a * room))


def _no_braking(deceleration_mps2: float, gradient_permille: float) -> str:
    """Why the net deceleration is not positive, in the terms the caller gave."""
    if deceleration_mps2 <= 0:
        return f"the braking deceleration must be positive (got {deceleration_mps2:g} m/s²)"
    return (
        f"the downhill gradient ({gradient_permille:g} ‰) overcomes the braking deceleration"
        f" ({deceleration_mps2:g} m/s²): the train would not stop"
    )
