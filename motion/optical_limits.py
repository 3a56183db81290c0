"""The inputs the smear meter accepts (seed ``000``, eq. 14–15): one documented table of
ranges, checked by :func:`motion.stripes.speed_from_image` itself, so the CLI's option
ranges and any other caller's are the same.

Found by the independent trial: ``--distance 1e300`` answered a speed of 1e301 km/h,
``--rows`` beyond the frame's height an extrapolated smear, and ``--row-time 1e-300`` a
speed of 1e300 km/h.  A value outside its range is refused with an
:class:`OpticalRangeError` naming the quantity, its unit, the range and the value; a
speed beyond any train (the inputs' combination is wrong) is refused the same way.

Re-exported by :mod:`motion.optical`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "OPTICAL_LIMITS",
    "OpticalLimits",
    "OpticalRangeError",
    "check_optical",
    "check_rows",
    "check_speed",
]


class OpticalRangeError(ValueError):
    """An input (or the speed it gives) outside :class:`OpticalLimits`; ``field`` names it."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field


@dataclass(frozen=True, slots=True)
class OpticalLimits:
    """Allowed ranges of the smear meter's inputs, SI units (exclusive of 0 where said).

    Physical plausibility, not tuning: beyond them is a unit mistake (mm given as m, µs as
    s) or a broken input.
    """

    # The stripes beside the line are about 1 m from a side camera (the paper's D); an
    # approach meter ranges to ~20 m.  100 m: no stripe is resolved farther.
    max_distance_m: float = 100.0
    # β, one pixel's angle: the paper's 0.94 mrad; 10 mrad is a 100-px-wide 57° camera,
    # 1 µrad a 1° field over 17,000 pixels.  Δω (pixel_error_rad) in the same range.
    min_pixel_fov_rad: float = 1e-6
    max_pixel_fov_rad: float = 0.01
    # t_c, one row's read-out time: 10 ns (a 1000-row frame in 10 µs) to 10 ms (10 s).
    min_row_time_s: float = 1e-8
    max_row_time_s: float = 1e-2
    # The measured speed: 150 m/s = 540 km/h is above any train (BRAKING_LIMITS.max_speed_mps).
    max_speed_mps: float = 150.0


OPTICAL_LIMITS = OpticalLimits()


def _check(field: str, value: float, low: float, high: float, unit: str, low_open: bool) -> None:
    below = value <= low if low_open else value < low
    if not math.isfinite(value) or below or value > high:
        bracket = "(" if low_open else "["
        raise OpticalRangeError(
            field,
            f"{field} must be a finite number in {bracket}{low:g}, {high:g}] {unit}"
            f" (got {value:g})",
        )


def check_optical(
    distance_m: float,
    pixel_fov_rad: float,
    row_time_s: float,
    pixel_error_rad: float | None,
    *,
    limits: OpticalLimits = OPTICAL_LIMITS,
) -> None:
    """:class:`OpticalRangeError` naming the first input outside its range."""
    lim = limits
    _check("distance_m", distance_m, 0.0, lim.max_distance_m, "m", True)
    beta = (lim.min_pixel_fov_rad, lim.max_pixel_fov_rad)
    _check("pixel_fov_rad", pixel_fov_rad, *beta, "rad", False)
    _check("row_time_s", row_time_s, lim.min_row_time_s, lim.max_row_time_s, "s", False)
    if pixel_error_rad is not None:
        _check("pixel_error_rad", pixel_error_rad, *beta, "rad", False)


def check_rows(rows: int, frame_rows: int) -> None:
    """``rows`` (h) must lie within the frame: a smear over more rows is not measured."""
    if not 1 <= rows <= frame_rows:
        raise OpticalRangeError(
            "rows",
            f"rows must be a whole number in [1, {frame_rows}] (the frame's height; got {rows}):"
            " the smear is measured over rows of this frame only",
        )


def check_speed(speed_mps: float, *, limits: OpticalLimits = OPTICAL_LIMITS) -> None:
    """A measured speed beyond any train means the geometry given is wrong."""
    if not math.isfinite(speed_mps) or abs(speed_mps) > limits.max_speed_mps:
        raise OpticalRangeError(
            "speed",
            f"the smear gives {speed_mps:.3g} m/s, beyond any train ({limits.max_speed_mps:g}"
            " m/s): check distance_m, row_time_s and pixel_fov_rad (their units)",
        )
