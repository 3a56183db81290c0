"""Speed along the track from the rolling-shutter smear of vertical stripes
(seed ``000``, section 2): equations (14)–(16) and the 40 km/h example.

Re-exported by :mod:`motion.optical`; see there for the conventions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .ranging import KMH_PER_MPS

# --------------------------------------------------------------------------
# Side camera on vertical stripes: equations (14)–(16)
# --------------------------------------------------------------------------


def _check_geometry(
    distance_m: float, pixel_fov_rad: float, rows: float, row_time_s: float
) -> None:
    if not (distance_m > 0 and pixel_fov_rad > 0 and rows > 0 and row_time_s > 0):
        raise ValueError("distance, pixel field of view, rows and row time must be positive")


def speed_from_smear(
    smear_px: float,
    *,
    distance_m: float,
    pixel_fov_rad: float,
    rows: float,
    row_time_s: float,
) -> float:
    """Equation (14): ``v = D·tan(s·β)/(h·t_c)``.

    ``smear_px`` is ``s``, the horizontal shift in pixels of a vertical
    stripe over ``rows`` (= ``h``) image rows.  A negative smear gives a
    negative speed (motion the other way).
    """
    _check_geometry(distance_m, pixel_fov_rad, rows, row_time_s)
    angle = smear_px * pixel_fov_rad
    if abs(angle) >= math.pi / 2:
        raise ValueError("smear angle s·β must be below 90°")
    return distance_m * math.tan(angle) / (rows * row_time_s)


def smear_for_speed(
    speed_mps: float,
    *,
    distance_m: float,
    pixel_fov_rad: float,
    rows: float,
    row_time_s: float,
) -> float:
    """Inverse of (14): the smear ``s = arctan(v·h·t_c/D)/β`` in pixels."""
    _check_geometry(distance_m, pixel_fov_rad, rows, row_time_s)
    return math.atan(speed_mps * rows * row_time_s / distance_m) / pixel_fov_rad


def speed_sigma_from_smear(
    smear_px: float,
    *,
    distance_m: float,
    pixel_fov_rad: float,
    rows: float,
    row_time_s: float,
    pixel_error_rad: float | None = None,
) -> float:
    """Equation (15): ``σ_v = D·(tan(s·β + Δω) - tan(s·β))/(h·t_c)``.

    ``pixel_error_rad`` (Δω) defaults to half a pixel, ``β/2``.
    """
    _check_geometry(distance_m, pixel_fov_rad, rows, row_time_s)
    dw = pixel_fov_rad / 2 if pixel_error_rad is None else pixel_error_rad
    a = abs(smear_px) * pixel_fov_rad
    return distance_m * (math.tan(a + dw) - math.tan(a)) / (rows * row_time_s)


def speed_sigma_roll_scatter(
    smear_px: float,
    *,
    distance_m: float,
    pixel_fov_rad: float,
    rows: float,
    row_time_s: float,
    roll_rad: float,
    distance_scatter_m: float,
    pixel_error_rad: float | None = None,
) -> float:
    """Equation (16), roll α and beacon distance scatter ΔD:

    ``σ_v = ((D + ΔD)·tan(s·β + Δω) - D·cos α·tan(s·β)) / (cos α·h·t_c)``.

    With α = 0 and ΔD = 0 it is equation (15).
    """
    _check_geometry(distance_m, pixel_fov_rad, rows, row_time_s)
    dw = pixel_fov_rad / 2 if pixel_error_rad is None else pixel_error_rad
    a = abs(smear_px) * pixel_fov_rad
    ca = math.cos(roll_rad)
    num = (distance_m + distance_scatter_m) * math.tan(a + dw) - distance_m * ca * math.tan(a)
    return num / (ca * rows * row_time_s)


def rows_for_stripe(height_m: float, distance_m: float, pixel_fov_rad: float) -> int:
    """Rows a stripe rising ``height_m`` above the optical axis covers:
    ``h = arctan(l/D)/β`` (1 m at D = 1 m, β = 0.94 mrad → 836 rows)."""
    return round(math.atan(height_m / distance_m) / pixel_fov_rad)


# --------------------------------------------------------------------------
# The paper's worked examples
# --------------------------------------------------------------------------

#: Section 2 of the paper: side camera on 1 m stripes at D = 1 m.
PAPER_EXAMPLE: dict[str, float] = {
    "distance_m": 1.0,
    "pixel_fov_rad": 0.94e-3,
    "pixel_error_rad": 0.47e-3,
    "row_time_s": 1e-4,
    "rows": 836,
    "speed_kmh": 40.0,
    "smear_px": 796,
    "roll_max_deg": 1.0,
    "roll_hz": 0.7,
    "scatter_max_m": 0.01,
    "duration_s": 45.0,
    "bound_kmh": 0.47,
    "bound_mps": 0.13,
}


@dataclass(frozen=True)
class RollScatterStudy:
    """Eq. (16) simulated over time: harmonic roll and uniform distance scatter."""

    smear_px: float
    times_s: list[float]
    sigma_mps: list[float]
    max_sigma_mps: float
    max_sigma_kmh: float
    bound_sigma_mps: float  # the worst case: α = α_max, ΔD = ΔD_max
    sigma15_mps: float  # no roll, no scatter: eq. (15)


def roll_scatter_study(
    *,
    speed_kmh: float = 40.0,
    distance_m: float = 1.0,
    pixel_fov_rad: float = 0.94e-3,
    pixel_error_rad: float = 0.47e-3,
    rows: float = 836,
    row_time_s: float = 1e-4,
    roll_max_deg: float = 1.0,
    roll_hz: float = 0.7,
    scatter_max_m: float = 0.01,
    duration_s: float = 45.0,
    rate_hz: float = 10.0,
    seed: int = 0,
) -> RollScatterStudy:
    """The paper's Fig. 7 experiment: σ_v of eq. (16) over ``duration_s`` with
    roll ``α(t) = α_max·sin(2π·f·t + φ0)`` and ``ΔD ~ U(0, ΔD_max)`` per frame,
    at the smear measured for ``speed_kmh`` (rounded to whole pixels)."""
    rng = np.random.default_rng(seed)
    geom = {
        "distance_m": distance_m,
        "pixel_fov_rad": pixel_fov_rad,
        "rows": rows,
        "row_time_s": row_time_s,
    }
    s = float(round(smear_for_speed(speed_kmh / KMH_PER_MPS, **geom)))
    n = int(round(duration_s * rate_hz)) + 1
    t = np.linspace(0.0, duration_s, n)
    phase = rng.uniform(0, 2 * math.pi)
    alpha = math.radians(roll_max_deg) * np.sin(2 * math.pi * roll_hz * t + phase)
    scatter = rng.uniform(0.0, scatter_max_m, n)
    sig = [
        speed_sigma_roll_scatter(
            s,
            **geom,
            roll_rad=float(a),
            distance_scatter_m=float(d),
            pixel_error_rad=pixel_error_rad,
        )
        for a, d in zip(alpha, scatter, strict=True)
    ]
    bound = speed_sigma_roll_scatter(
        s,
        **geom,
        roll_rad=math.radians(roll_max_deg),
        distance_scatter_m=scatter_max_m,
        pixel_error_rad=pixel_error_rad,
    )
    s15 = speed_sigma_from_smear(s, **geom, pixel_error_rad=pixel_error_rad)
    mx = max(sig)
    return RollScatterStudy(
        smear_px=s,
        times_s=t.tolist(),
        sigma_mps=sig,
        max_sigma_mps=mx,
        max_sigma_kmh=mx * KMH_PER_MPS,
        bound_sigma_mps=bound,
        sigma15_mps=s15,
    )
