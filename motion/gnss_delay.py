"""The GNSS speed delay from the sharp changes of both speeds (seed ``004``:
"sharp changes in both are aligned in time using the GNSS delay")."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["estimate_gnss_delay"]


def estimate_gnss_delay(
    t: Sequence[float] | npt.NDArray[np.float64],
    accel_mps2: Sequence[float] | npt.NDArray[np.float64],
    t_gnss: Sequence[float] | npt.NDArray[np.float64],
    speed_gnss_mps: Sequence[float] | npt.NDArray[np.float64],
    *,
    max_delay_s: float = 5.0,
    step_s: float = 0.02,
) -> float:
    """Estimate the GNSS speed delay by aligning the changes of both speeds.

    ``t_gnss`` are the times the GNSS speeds *arrived*.  For every candidate
    delay ``d`` the accelerometer speed ``V_a = ∫a dt`` is read at
    ``t_gnss - d`` and the increments of ``V_a`` and of ``V_gnss`` between
    consecutive fixes are compared (a constant bias becomes a constant
    offset of the increments and is removed); the delay with the smallest
    residual wins.  Sharp speed changes (starting, braking) dominate.
    """
    ta = np.asarray(t, dtype=np.float64)
    aa = np.asarray(accel_mps2, dtype=np.float64)
    tg = np.asarray(t_gnss, dtype=np.float64)
    vg = np.asarray(speed_gnss_mps, dtype=np.float64)
    if ta.size < 3 or tg.size < 3:
        raise ValueError("need at least three samples of each")
    va = np.concatenate([[0.0], np.cumsum((aa[1:] + aa[:-1]) / 2 * np.diff(ta))])
    dvg = np.diff(vg)
    dtg = np.diff(tg)
    best_d, best_r = 0.0, math.inf
    for d in np.arange(0.0, max_delay_s + step_s / 2, step_s):
        tq = tg - d
        ok = (tq[:-1] >= ta[0]) & (tq[1:] <= ta[-1])
        if ok.sum() < 3:
            continue
        v = np.interp(tq, ta, va)
        dva = np.diff(v)
        res = dva[ok] - dvg[ok]
        # remove the bias: a constant acceleration offset times the interval
        k = float(np.sum(res * dtg[ok]) / np.sum(dtg[ok] ** 2))
        r = float(np.mean((res - k * dtg[ok]) ** 2))
        if r < best_r:
            best_r, best_d = r, float(d)
    return best_d
