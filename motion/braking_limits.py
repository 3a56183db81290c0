"""The inputs the braking calculators accept (seed ``001``): one documented
table of ranges, checked by the domain functions themselves so that the API
and the CLI refuse the same values with the same message.

A value outside its range is refused with a :class:`ValueError` naming the
quantity, its unit and the allowed range — never turned into a protective
section that inverts the margin (a negative ``ΔL_max`` "meeting SIL-4"), a
probability bound of 0, or a NaN braking distance.

Re-exported by :mod:`motion.braking`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["BRAKING_LIMITS", "BrakingLimits", "check_range"]


@dataclass(frozen=True, slots=True)
class BrakingLimits:
    """Allowed ranges (inclusive unless said) of the braking calculators' inputs, SI units.

    The bounds are physical plausibility, not tuning: a value beyond them is a
    unit mistake (km/h given as m/s, ‰ as %), or a broken input.
    """

    # 150 m/s = 540 km/h: above any train in service.
    max_speed_mps: float = 150.0
    # Braking deceleration, exclusive of 0: 5 m/s² is twice an emergency brake
    # with magnetic track brakes (about 2.7 m/s²).
    max_deceleration_mps2: float = 5.0
    max_reaction_time_s: float = 60.0
    # Adhesion railways stay within about ±60 ‰ (the steepest lines ~70 ‰);
    # a larger value is a unit mistake (‰ versus %, or a rack railway).
    max_abs_gradient_permille: float = 70.0
    # Error bounds of the protective section (non-negative: a negative margin
    # would move the braking point towards the obstacle).
    max_margin_m: float = 10_000.0
    max_measurement_time_s: float = 60.0
    # Probabilities of exceeding a margin: in (0, 1]; 0 would claim certainty.
    max_measurements: int = 100
    max_channels: int = 10
    # Track coordinates, as for markers.
    max_abs_coordinate_m: float = 5_000_000.0
    # A Monte Carlo study needs two runs for a spread; a million takes minutes on 2 cores.
    min_monte_carlo_runs: int = 2
    max_monte_carlo_runs: int = 1_000_000


BRAKING_LIMITS = BrakingLimits()


def check_range(
    name: str,
    value: float,
    low: float,
    high: float,
    unit: str,
    *,
    low_open: bool = False,
) -> float:
    """``value`` if it is a finite number in ``[low, high]`` (``(low, high]``
    with ``low_open``); else ``ValueError`` naming the quantity, unit and range."""
    v = float(value)
    below = v <= low if low_open else v < low
    if not math.isfinite(v) or below or v > high:
        bracket = "(" if low_open else "["
        unit_s = f" {unit}" if unit else ""
        raise ValueError(
            f"{name} must be a finite number in {bracket}{low:g}, {high:g}]{unit_s} (got {v:g})"
        )
    return v
