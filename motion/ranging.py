"""Ranging and approach speed (seed ``000``, section 1): equations (1)–(13)
and Table 1 of Starovoitov & Vorobiev (2015).

Re-exported by :mod:`motion.optical`; see there for the conventions.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

KMH_PER_MPS = 3.6


# --------------------------------------------------------------------------
# 1. Approach speed from two ranges: equations (1), (2), (9), (10)
# --------------------------------------------------------------------------


def approach_speed(d1_m: float, d2_m: float, t1_s: float, t2_s: float) -> float:
    """Equations (1)–(2): ``v = (D1 - D2)/Δt`` with ``Δt = t2 - t1``."""
    dt = t2_s - t1_s
    if dt <= 0:
        raise ValueError("t2 must be later than t1")
    return (d1_m - d2_m) / dt


def approach_speed_sigma(
    v_mps: float,
    sigma_d1_m: float,
    sigma_d2_m: float,
    dt_s: float,
    sigma_dt_s: float = 0.0,
) -> float:
    """Equation (9): ``σ_v²/v² = (σ_D1² + σ_D2²)/(v²Δt²) + σ_Δt²/Δt²``; returns σ_v."""
    if dt_s <= 0:
        raise ValueError("dt_s must be positive")
    var = (sigma_d1_m**2 + sigma_d2_m**2) / dt_s**2 + (v_mps * sigma_dt_s / dt_s) ** 2
    return math.sqrt(var)


def approach_speed_sigma_simple(sigma_d1_m: float, sigma_d2_m: float, dt_s: float) -> float:
    """Equation (10): ``σ_v = √(σ_D1² + σ_D2²)/Δt`` (timing error neglected)."""
    return approach_speed_sigma(0.0, sigma_d1_m, sigma_d2_m, dt_s, 0.0)


# --------------------------------------------------------------------------
# Stereo pair: equations (3), (4)
# --------------------------------------------------------------------------


def stereo_range(base_m: float, focal_m: float, parallax_m: float) -> float:
    """Equation (3): ``D = l_T·f/p`` (p: linear parallax on the sensor, metres)."""
    if parallax_m <= 0:
        raise ValueError("parallax must be positive")
    return base_m * focal_m / parallax_m


def stereo_parallax(base_m: float, focal_m: float, distance_m: float) -> float:
    """Inverse of (3): the parallax ``p = l_T·f/D`` of an object at ``D``."""
    return base_m * focal_m / distance_m


def stereo_range_sigma(
    base_m: float, focal_m: float, parallax_m: float, parallax_error: float
) -> float:
    """Equation (4): ``σ_D = (f·l_T/p)·Δω/(p + Δω)``.

    ``parallax_error`` must be in the units of ``p`` (metres on the sensor).
    The paper puts Δω = 0.47e-3 (an angle) here directly; the consistent
    value is ``f·Δω``.  See the module notes.
    """
    return (focal_m * base_m / parallax_m) * parallax_error / (parallax_m + parallax_error)


# --------------------------------------------------------------------------
# Angle meter on an object of known size: equations (5)–(7)
# --------------------------------------------------------------------------


def angle_range(size_m: float, angle_rad: float) -> float:
    """Equation (5): ``D = l/tan φ``."""
    return size_m / math.tan(angle_rad)


def apparent_angle(size_m: float, distance_m: float) -> float:
    """Equation (6): ``φ = arctan(l/D)``."""
    return math.atan(size_m / distance_m)


def angle_range_sigma(
    size_m: float, angle_rad: float, size_error_m: float, angle_error_rad: float
) -> float:
    """Equation (7): ``σ_D = (l + Δl)/tan(φ + Δω) - l/tan φ``."""
    return (size_m + size_error_m) / math.tan(angle_rad + angle_error_rad) - size_m / math.tan(
        angle_rad
    )


# --------------------------------------------------------------------------
# Beacon rectangle on a rolling shutter: equations (8), (11)–(13)
# --------------------------------------------------------------------------


def beacon_range_sigma(base_m: float, angle_rad: float, angle_error_rad: float) -> float:
    """Equation (8): ``σ_D = l_M·(tan(φ+Δω) - tan φ)/(tan φ·tan(φ+Δω))``."""
    t0 = math.tan(angle_rad)
    t1 = math.tan(angle_rad + angle_error_rad)
    return base_m * (t1 - t0) / (t0 * t1)


def smear_interval(row_time_s: float, rows: float) -> float:
    """Equation (11): ``Δt = t_c·h``."""
    return row_time_s * rows


def max_second_range(d1_m: float, sigma_d1_m: float) -> float:
    """Equation (12): the second range must satisfy ``D2 ≤ D1 - σ_D1``; returns the limit."""
    return d1_m - sigma_d1_m


def min_interval(sigma_d1_m: float, v_mps: float) -> float:
    """Equation (13): ``Δt ≥ σ_D1/v``; returns the smallest admissible Δt."""
    if v_mps <= 0:
        raise ValueError("speed must be positive")
    return sigma_d1_m / v_mps


# --------------------------------------------------------------------------
# Table 1
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Table1Params:
    """The inputs of the paper's Table 1."""

    v_mps: float = 2.0
    stereo_base_m: float = 2.5  # l_T
    focal_m: float = 0.1  # f
    object_size_m: float = 2.7  # l (car width)
    object_size_error_m: float = 0.1  # Δl
    beacon_base_m: float = 2.5  # l_M
    pixel_fov_rad: float = 0.94e-3  # β = 55°/1024
    pixel_error_rad: float = 0.47e-3  # Δω
    d1_m: float = 20.0
    dt_s: float = 1.0  # stereo and angle meter
    smear_dt_s: float = 0.2  # smear sensor, Δt = t_c·h
    row_time_s: float = 1.5e-3  # t_c of the smear sensor


@dataclass(frozen=True)
class Table1Row:
    meter: str
    d1_m: float
    sigma_d1_m: float
    d2_m: float
    sigma_d2_m: float
    dt_s: float
    sigma_v_mps: float
    sigma_v_kmh: float  # σ_v·3.6, unrounded
    sigma_v_kmh_paper_style: float  # round(σ_v, 2)·3.6, as the paper prints it
    note: str = ""

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


#: Table 1 as printed: meter → (D1, σ_D1, D2, σ_D2, σ_v m/s, σ_v km/h).
PAPER_TABLE1: dict[str, tuple[float, float, float, float, float, float]] = {
    "stereo": (20.00, 0.72, 18.00, 0.59, 0.93, 3.35),
    "angle": (20.00, 0.67, 18.00, 0.61, 0.90, 3.24),
    "smear": (20.00, 0.08, 19.60, 0.07, 0.53, 1.91),
}


def _row(meter: str, d1: float, s1: float, d2: float, s2: float, dt: float, note: str) -> Table1Row:
    sv = approach_speed_sigma_simple(s1, s2, dt)
    return Table1Row(
        meter=meter,
        d1_m=d1,
        sigma_d1_m=s1,
        d2_m=d2,
        sigma_d2_m=s2,
        dt_s=dt,
        sigma_v_mps=sv,
        sigma_v_kmh=sv * KMH_PER_MPS,
        sigma_v_kmh_paper_style=round(round(sv, 2) * KMH_PER_MPS, 2),
        note=note,
    )


def table1(params: Table1Params | None = None) -> list[Table1Row]:
    """Table 1 of the paper, computed.

    Rows: ``stereo`` (paper's convention, Δω in metres in eq. 4),
    ``stereo_consistent`` (parallax error ``f·Δω``), ``angle`` (eq. 5–7)
    and ``smear`` (eq. 8, 11).  D2 = D1 - v·Δt.
    """
    p = params or Table1Params()
    d1 = p.d1_m
    rows: list[Table1Row] = []

    d2 = d1 - p.v_mps * p.dt_s
    par1 = stereo_parallax(p.stereo_base_m, p.focal_m, d1)
    par2 = stereo_parallax(p.stereo_base_m, p.focal_m, d2)
    rows.append(
        _row(
            "stereo",
            d1,
            stereo_range_sigma(p.stereo_base_m, p.focal_m, par1, p.pixel_error_rad),
            d2,
            stereo_range_sigma(p.stereo_base_m, p.focal_m, par2, p.pixel_error_rad),
            p.dt_s,
            f"paper's convention: Δω = {p.pixel_error_rad:g} used as metres on the sensor",
        )
    )
    pitch = p.focal_m * p.pixel_error_rad
    rows.append(
        _row(
            "stereo_consistent",
            d1,
            stereo_range_sigma(p.stereo_base_m, p.focal_m, par1, pitch),
            d2,
            stereo_range_sigma(p.stereo_base_m, p.focal_m, par2, pitch),
            p.dt_s,
            f"parallax error f·Δω = {pitch * 1e6:.0f} µm on the sensor (not in the paper)",
        )
    )
    rows.append(
        _row(
            "angle",
            d1,
            angle_range_sigma(
                p.object_size_m,
                apparent_angle(p.object_size_m, d1),
                p.object_size_error_m,
                p.pixel_error_rad,
            ),
            d2,
            angle_range_sigma(
                p.object_size_m,
                apparent_angle(p.object_size_m, d2),
                p.object_size_error_m,
                p.pixel_error_rad,
            ),
            p.dt_s,
            f"Δl = {p.object_size_error_m:g} m",
        )
    )
    d2s = d1 - p.v_mps * p.smear_dt_s
    h = p.smear_dt_s / p.row_time_s
    rows.append(
        _row(
            "smear",
            d1,
            beacon_range_sigma(
                p.beacon_base_m, apparent_angle(p.beacon_base_m, d1), p.pixel_error_rad
            ),
            d2s,
            beacon_range_sigma(
                p.beacon_base_m, apparent_angle(p.beacon_base_m, d2s), p.pixel_error_rad
            ),
            smear_interval(p.row_time_s, h),
            f"Δt = t_c·h = {p.row_time_s:g} s × {h:.0f} rows",
        )
    )
    return rows
