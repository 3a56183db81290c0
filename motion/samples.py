"""Inputs, outputs and tuning of :class:`motion.fusion.TrackFilter`, and the
rules a ``motion_sample`` must satisfy (:data:`SAMPLE_LIMITS`,
:func:`sample_problem`): written once here and used both by the API schema
(``ingest/schemas.py``: a sample that breaks them is answered 422) and by the
filter, so a sample the API accepts is always applied."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from typing import Any

__all__ = [
    "SAMPLE_LIMITS",
    "FilterConfig",
    "MotionSample",
    "SampleLimits",
    "SampleRuleError",
    "ClockJumpError",
    "StaleSampleError",
    "TrackState",
    "check_sample",
    "coerce_sample",
    "sample_problem",
]


class StaleSampleError(ValueError):
    """The sample is refused, the estimate kept: later than the late-sample bound
    (``FilterConfig.max_delay_s``), or one of a run that is not yet confirmed."""


class ClockJumpError(StaleSampleError):
    """The sample lies far ahead of the newest (``FilterConfig.max_gap_s``): one of a
    forward clock jump that ``restart_confirm_samples`` samples in a row must confirm."""


class SampleRuleError(ValueError):
    """A sample breaks one of the :class:`SampleLimits` rules; ``field`` names it."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field


@dataclass(frozen=True, slots=True)
class SampleLimits:
    """Plausible values of a ``motion_sample`` (protocol v1); SI units, degrees.

    A sample outside them comes from a broken or misconfigured on-board unit
    and is refused as a whole (HTTP 422; ``ValueError`` from the filter),
    never stored and then skipped.  Besides these bounds every value must be
    a finite number, and ``gnss_lat``/``gnss_lon`` come together or not at all.
    """

    # |a| above 5 g is a sensor-scale error (mg or ft/s² sent as m/s²), not a train.
    max_abs_accel_mps2: float = 50.0
    # Exclusive: 200 m/s = 720 km/h is above any train; a receiver reporting it is broken.
    max_gnss_speed_mps: float = 200.0
    # Inclusive: how late a GNSS speed may report; the filter uses one only
    # while it is inside its buffer (``FilterConfig.max_delay_s``).
    max_gnss_delay_s: float = 600.0
    max_abs_lat_deg: float = 90.0
    max_abs_lon_deg: float = 180.0
    # The on-board clock, s: 1e10 s (317 years) admits a Unix-time clock; a
    # larger |t| is a broken clock (and at 1e308 every time difference overflows).
    max_abs_t_s: float = 1e10


SAMPLE_LIMITS = SampleLimits()


def _not_finite(**values: float | None) -> str | None:
    for name, v in values.items():
        if v is not None and not math.isfinite(v):
            return name
    return None


def sample_problem(
    t: float,
    accel_mps2: float,
    gnss_speed_mps: float | None,
    delay_s: float | None,
    gnss_lat: float | None,
    gnss_lon: float | None,
    *,
    limits: SampleLimits = SAMPLE_LIMITS,
) -> tuple[str, str] | None:
    """The first rule a sample breaks, as ``(field, message)``; ``None`` when it is valid.

    ``delay_s`` is the sample's ``gnss_delay_s`` (``None``: not given).
    """
    bad = _not_finite(
        t=t,
        accel_mps2=accel_mps2,
        gnss_speed_mps=gnss_speed_mps,
        gnss_delay_s=delay_s,
        gnss_lat=gnss_lat,
        gnss_lon=gnss_lon,
    )
    if bad is not None:
        return bad, f"{bad} must be a finite number"
    lim = limits
    if abs(t) > lim.max_abs_t_s:
        return "t", (
            f"t must be within ±{lim.max_abs_t_s:g} s (the on-board clock, in seconds):"
            " check the unit's clock"
        )
    if abs(accel_mps2) > lim.max_abs_accel_mps2:
        return "accel_mps2", (
            f"accel_mps2 out of range (|a| > {lim.max_abs_accel_mps2:g} m/s²): "
            "check the sensor scale"
        )
    if gnss_speed_mps is not None and not (0.0 <= gnss_speed_mps < lim.max_gnss_speed_mps):
        return "gnss_speed_mps", (
            f"gnss_speed_mps must be in [0, {lim.max_gnss_speed_mps:g}) m/s (a speed over ground)"
        )
    if delay_s is not None and not (0.0 <= delay_s <= lim.max_gnss_delay_s):
        return "gnss_delay_s", f"gnss_delay_s must be in [0, {lim.max_gnss_delay_s:g}] s"
    if (gnss_lat is None) != (gnss_lon is None):
        missing = "gnss_lon" if gnss_lon is None else "gnss_lat"
        return missing, "gnss_lat and gnss_lon must be given together (a GNSS fix has both)"
    if gnss_lat is not None and abs(gnss_lat) > lim.max_abs_lat_deg:
        return (
            "gnss_lat",
            f"gnss_lat must be in [-{lim.max_abs_lat_deg:g}, {lim.max_abs_lat_deg:g}]°",
        )
    if gnss_lon is not None and abs(gnss_lon) > lim.max_abs_lon_deg:
        return (
            "gnss_lon",
            f"gnss_lon must be in [-{lim.max_abs_lon_deg:g}, {lim.max_abs_lon_deg:g}]°",
        )
    return None


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
    # +1 increasing coordinate, -1 decreasing, 0 standstill or not known (motion.direction:
    # then speed_mps is a magnitude and the position is the midpoint of both ways)
    direction: int
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
    # GNSS speeds jumped by more than any brake gives (a lost fix reads 0) and the gate
    # refuses them: the speed is the accelerometer's alone (motion.policy).  In
    # ``as_dict`` only while true, so states of a filter that never saw it keep their form.
    gnss_disagrees: bool = False

    @property
    def speed_kmh(self) -> float:
        return abs(self.speed_mps) * 3.6

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["missed_marker_ids"] = list(self.missed_marker_ids)
        if not self.gnss_disagrees:
            del d["gnss_disagrees"]
        return d


@dataclass(frozen=True)
class FilterConfig:
    """Tuning of :class:`TrackFilter` (SI units).

    The fields after ``standstill_mps`` were added after snapshot version 1;
    a snapshot records them only when they differ from their defaults, so
    snapshots of default-tuned filters keep the version-1 form.
    """

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
    # The buffer length: the largest GNSS delay handled, and the late-sample bound: a
    # sample up to this much behind the newest is used (inserted and the filter re-run),
    # an older one refused with the reason (StaleSampleError).
    max_delay_s: float = 5.0
    reader_margin_m: float = 30.0
    missed_zone_m: float = 400.0
    initial_position_m: float | None = None  # None: unknown until a marker or fix
    initial_position_sigma: float = 5.0
    initial_speed_mps: float = 0.0
    # Unknown by default: a filter may start (an on-board unit restarting, a
    # train first seen by the service) while the train runs; the first GNSS
    # speed sets it.  Give a small σ only when the start is known to be standing.
    initial_speed_sigma: float = 100.0
    unknown_position_sigma: float = 1e5
    lost_position_sigma: float = 50.0  # σ beyond which the position counts as unknown
    standstill_mps: float = 0.05
    # -- added after snapshot version 1 (see the class documentation) --
    # A projected fix farther than fix_offset_sigmas·gnss_position_sigma +
    # fix_offset_margin_m from the track geometry is not on this line (another
    # track, a multipath fix): it is not used.
    fix_offset_sigmas: float = 5.0
    fix_offset_margin_m: float = 50.0
    # The direction of motion is reported only when |speed| exceeds this many
    # σ of speed (and standstill_mps).
    direction_sigmas: float = 2.0
    # σ of speed beyond which the speed counts as unknown (a person must look).
    lost_speed_sigma: float = 5.0
    # This many GNSS speeds in a row rejected by the gate mean the estimate,
    # not the receiver, is wrong (the gate would otherwise lock GNSS out for
    # good): speed and bias start again from the next GNSS speed, and the
    # position, integrated from the wrong speed, becomes unknown.
    gnss_reject_limit: int = 5
    # The σ of speed given to a speed that starts again (unknown).
    unknown_speed_sigma: float = 100.0
    # The largest gap between samples the filter integrates across, s.  Samples
    # further after the newest (the unit was off, or its clock jumped) start the filter
    # again with position and speed unknown once restart_confirm_samples of them in a
    # row confirm the jump; fewer are refused (ClockJumpError), the estimate kept: one
    # corrupt time stamp must not wipe a good estimate.
    max_gap_s: float = 30.0
    # An on-board restart (motion.restart): this many samples in a row more than
    # restart_jump_s behind the newest, running forward among themselves, start the
    # filter again from the last of them (speed and position unknown).  Fewer are
    # late samples and refused.
    restart_jump_s: float = 30.0
    restart_confirm_samples: int = 3

    def __post_init__(self) -> None:
        if self.orientation not in (1, -1):
            raise ValueError("orientation must be +1 or -1")
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float) and not math.isfinite(v):
                raise ValueError(f"{f.name} must be finite")
        if self.max_delay_s <= 0 or self.sample_rate_hz <= 0:
            raise ValueError("max_delay_s and sample_rate_hz must be positive")
        if self.max_gap_s < self.max_delay_s:
            raise ValueError("max_gap_s must be at least max_delay_s")
        if self.gnss_reject_limit < 1:
            raise ValueError("gnss_reject_limit must be at least 1")
        if self.restart_jump_s < self.max_delay_s or self.restart_confirm_samples < 1:
            raise ValueError(
                "restart_jump_s must be at least max_delay_s, restart_confirm_samples at least 1"
            )


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
    delay_s: float | None,
    gnss_lat: float | None,
    gnss_lon: float | None,
    *,
    limits: SampleLimits = SAMPLE_LIMITS,
) -> None:
    """Raise :class:`SampleRuleError` naming the first rule the sample breaks.

    The same rules as :func:`sample_problem`, tested first in one expression
    (the filter calls this for every sample); every comparison with NaN or an
    infinity outside the limits is false, so those reach the full check.
    """
    lim = limits
    if (
        -lim.max_abs_t_s <= t <= lim.max_abs_t_s
        and -lim.max_abs_accel_mps2 <= accel_mps2 <= lim.max_abs_accel_mps2
        and (gnss_speed_mps is None or 0.0 <= gnss_speed_mps < lim.max_gnss_speed_mps)
        and (delay_s is None or 0.0 <= delay_s <= lim.max_gnss_delay_s)
        and (
            (gnss_lat is None and gnss_lon is None)
            or (
                gnss_lat is not None
                and gnss_lon is not None
                and -lim.max_abs_lat_deg <= gnss_lat <= lim.max_abs_lat_deg
                and -lim.max_abs_lon_deg <= gnss_lon <= lim.max_abs_lon_deg
            )
        )
    ):
        return
    problem = sample_problem(
        t, accel_mps2, gnss_speed_mps, delay_s, gnss_lat, gnss_lon, limits=limits
    )
    if problem is not None:
        raise SampleRuleError(*problem)
