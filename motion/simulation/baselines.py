"""What the fusion is measured against: each sensor alone."""

from __future__ import annotations

from ..model import PER_MILLE, G
from .generator import Run

__all__ = ["dead_reckoning", "gnss_only"]


def dead_reckoning(run: Run) -> float:
    """Baseline: accelerometer integrated twice from the known start, the
    gradient removed with the track profile, the bias unknown.  Returns the
    final track coordinate (m)."""
    t = run.t
    a = run.accel_meas
    s = run.start_estimate_m
    v = 0.0
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        gi = G * run.table.gradient_at(s) / PER_MILLE
        a0 = a[k - 1] - gi
        a1 = a[k] - gi
        s += v * dt + (2 * a0 + a1) / 6 * dt * dt
        v += (a0 + a1) / 2 * dt
    return float(s)


def gnss_only(run: Run) -> float:
    """Baseline: the newest GNSS fix projected on the track, advanced by the
    newest GNSS speed over its age (delay included); 0 if none.  Returns the
    final track coordinate (m)."""
    last_s: float | None = None
    last_v = 0.0
    last_t = 0.0
    for k in sorted(run.gnss_fix):
        lat, lon = run.gnss_fix[k]
        s_fix, _ = run.table.project(lat, lon)
        last_s = s_fix
        last_v = run.gnss_speed.get(k, last_v)
        last_t = float(run.t[k]) - run.delay_s
    if last_s is None:
        return 0.0
    return last_s + last_v * (float(run.t[-1]) - last_t)
