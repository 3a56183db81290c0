"""Inputs, outputs and tuning of :class:`motion.fusion.TrackFilter`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any

__all__ = ["FilterConfig", "MotionSample", "StaleSampleError", "TrackState", "coerce_sample"]


class StaleSampleError(ValueError):
    """The sample is older than the filter's buffer; it cannot be used."""


@dataclass(frozen=True, slots=True)
class MotionSample:
    """One ``motion_sample`` event (see ``protocol.md``)."""

    t: float
    accel_mps2: float
    gnss_speed_mps: float | None = None
    gnss_delay_s: float | None = None
    marker_id: str | None = None
    gnss_lat: float | None = None
    gnss_lon: float | None = None


@dataclass(frozen=True, slots=True)
class TrackState:
    """The filter's estimate at time ``t`` (the newest sample)."""

    t: float
    position_m: float  # track coordinate
    speed_mps: float  # signed: positive towards increasing coordinate
    acceleration_mps2: float  # along increasing coordinate, bias and gradient removed
    direction: int  # +1 increasing coordinate, -1 decreasing, 0 standstill
    sigma_position_m: float
    sigma_speed_mps: float
    sigma_acceleration_mps2: float
    accel_bias_mps2: float
    sigma_bias_mps2: float
    position_known: bool
    reader_on: bool
    next_marker_id: str | None
    distance_to_next_marker_m: float | None
    last_marker_id: str | None
    missed_marker_ids: tuple[str, ...]
    section: str | None
    gnss_age_s: float | None  # time since the newest GNSS speed was measured

    @property
    def speed_kmh(self) -> float:
        return abs(self.speed_mps) * 3.6

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["missed_marker_ids"] = list(self.missed_marker_ids)
        return d


@dataclass(frozen=True)
class FilterConfig:
    """Tuning of :class:`TrackFilter` (SI units)."""

    orientation: int = 1  # +1: the car's forward axis points to increasing coordinate
    accel_noise_mps2: float = 0.05  # per-sample accelerometer noise (vibration)
    sample_rate_hz: float = 10.0  # nominal accelerometer sample rate
    accel_model_psd: float = 1e-4  # extra acceleration noise (m²/s³): gradient and model errors
    bias_sigma0: float = 0.05  # initial accelerometer-bias uncertainty
    bias_walk: float = 3e-5  # bias random walk, m/s² per √s
    gnss_speed_sigma: float = 0.05  # m/s
    gnss_delay_s: float = 0.0  # used when a sample carries no gnss_delay_s
    gnss_gate: float = 6.0  # reject GNSS speeds farther than this many σ
    gnss_position_sigma: float = 12.0  # one fix projected on the track, m
    gnss_fix_interval_s: float = 5.0  # at most one fix per interval
    marker_sigma: float = 0.5  # m
    max_delay_s: float = 5.0  # buffer length: the largest GNSS delay handled
    reader_margin_m: float = 30.0
    missed_zone_m: float = 400.0
    initial_position_m: float | None = None  # None: unknown until a marker or fix
    initial_position_sigma: float = 5.0
    initial_speed_mps: float = 0.0
    initial_speed_sigma: float = 0.05
    unknown_position_sigma: float = 1e5
    lost_position_sigma: float = 50.0  # σ beyond which the position counts as unknown
    standstill_mps: float = 0.05

    def __post_init__(self) -> None:
        if self.orientation not in (1, -1):
            raise ValueError("orientation must be +1 or -1")
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float) and not math.isfinite(v):
                raise ValueError(f"{f.name} must be finite")
        if self.max_delay_s <= 0 or self.sample_rate_hz <= 0:
            raise ValueError("max_delay_s and sample_rate_hz must be positive")


def _opt_float(d: Mapping[str, Any], key: str) -> float | None:
    v = d.get(key)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"{key} must be a number")
    return float(v)


def coerce_sample(sample: MotionSample | Mapping[str, Any]) -> MotionSample:
    if isinstance(sample, MotionSample):
        return sample
    if not isinstance(sample, Mapping):
        raise ValueError("a sample must be a MotionSample or a mapping")
    if "t" not in sample or "accel_mps2" not in sample:
        raise ValueError("a sample needs t and accel_mps2")
    t = _opt_float(sample, "t")
    a = _opt_float(sample, "accel_mps2")
    assert t is not None and a is not None
    mid = sample.get("marker_id")
    if mid is not None and (isinstance(mid, bool) or not isinstance(mid, (str, int))):
        raise ValueError("marker_id must be a string or an integer")
    return MotionSample(
        t=t,
        accel_mps2=a,
        gnss_speed_mps=_opt_float(sample, "gnss_speed_mps"),
        gnss_delay_s=_opt_float(sample, "gnss_delay_s"),
        marker_id=None if mid is None else str(mid),
        gnss_lat=_opt_float(sample, "gnss_lat"),
        gnss_lon=_opt_float(sample, "gnss_lon"),
    )


def check_sample(
    t: float,
    accel_mps2: float,
    gnss_speed_mps: float | None,
    delay_s: float,
    gnss_lat: float | None,
    gnss_lon: float | None,
) -> None:
    """Raise ``ValueError`` naming the first implausible field of a sample."""
    if not (math.isfinite(t) and math.isfinite(accel_mps2)):
        raise ValueError("t and accel_mps2 must be finite numbers")
    if abs(accel_mps2) > 50.0:
        raise ValueError("accel_mps2 out of range (|a| > 50 m/s²): check the sensor scale")
    if gnss_speed_mps is not None and not (0.0 <= gnss_speed_mps < 200.0):
        raise ValueError("gnss_speed_mps must be in [0, 200) m/s (a speed over ground)")
    if not (0.0 <= delay_s < 3600.0):
        raise ValueError("gnss_delay_s must be in [0, 3600) s")
    if (gnss_lat is None) != (gnss_lon is None):
        raise ValueError("gnss_lat and gnss_lon must be given together")
    if (
        gnss_lat is not None
        and gnss_lon is not None
        and not (-90.0 <= gnss_lat <= 90.0 and -180.0 <= gnss_lon <= 180.0)
    ):
        raise ValueError("gnss_lat/gnss_lon out of range (degrees)")
