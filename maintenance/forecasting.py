"""Forecast of the quality index with prediction intervals and band exit (eq. 4.3).

The index is modelled as an optional linear trend plus a stationary AR(p)
part fitted by Yule–Walker. Intervals come from the AR noise and ψ-weights
(``var_h = σ²·Σ_{j<h} ψ_j²``); with a trend, the trend's own uncertainty is
added using the long-run variance of the AR part, ``σ²/(1 − Σa)²``, because
ordinary least squares understates it for correlated residuals.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from scipy.signal import lfilter, lfiltic
from scipy.special import ndtr, ndtri

from maintenance._checks import FloatArray, as_vector, check_band, check_positive_int
from maintenance.linear_prediction import psi_weights, yule_walker

Trend = Literal["none", "linear", "quadratic"]
TREND_DEGREE = {"none": -1, "linear": 1, "quadratic": 2}
MIN_UNIT_ROOT_GAP = 0.05  # keeps σ/(1 − Σa) finite for near-unit-root fits


@dataclass(frozen=True)
class Forecast:
    """Index forecast ``horizon`` steps past the last sample.

    Attributes
    ----------
    values, lower, upper, std : ndarray, shape (horizon,)
        Predicted index, interval bounds at ``level`` and forecast standard
        deviation for steps ``1 … horizon`` (same units as the index).
    exit_probability : ndarray, shape (horizon,)
        Probability that the index is outside ``band`` at each step (Gaussian).
    first_exit : int or None
        First step (1-based) whose predicted value is outside ``band``.
    risk : float
        ``max(exit_probability)``: probability of being outside the band at the
        worst step, a lower bound of the probability of leaving it within the
        horizon (tight when the trend's uncertainty dominates).
    coefficients : ndarray, shape (order,)
        AR coefficients ``a_1 … a_p``.
    noise_variance : float
        AR one-step noise variance ``σ²``.
    slope : float
        Trend per step (0 for ``trend="none"``).
    band : tuple of float
        The ``(lower, upper)`` band used.
    level : float
        Two-sided coverage of the interval.
    """

    values: FloatArray
    lower: FloatArray
    upper: FloatArray
    std: FloatArray
    exit_probability: FloatArray
    first_exit: int | None
    risk: float
    coefficients: FloatArray
    noise_variance: float
    slope: float
    band: tuple[float, float]
    level: float


def minimum_history(order: int, trend: Trend = "none") -> int:
    """Fewest samples :func:`forecast` accepts for ``order`` and ``trend``."""
    return int(order) + 2 + max(TREND_DEGREE.get(trend, 0), 0)


def _fit_ar(residual: FloatArray, order: int) -> tuple[FloatArray, float]:
    if float(np.ptp(residual)) <= 1e-12 * max(1.0, float(np.abs(residual).max())):
        return np.zeros(order), 0.0  # constant part: nothing random left to model
    return yule_walker(residual, order)


def _ar_path(residual: FloatArray, a: FloatArray, horizon: int) -> FloatArray:
    """Mean-removed AR recursion continued ``horizon`` steps past the data."""
    denominator = np.r_[1.0, -a]
    state = lfiltic([1.0], denominator, residual[::-1][: a.shape[0]])
    path, _ = lfilter([1.0], denominator, np.zeros(horizon), zi=state)
    return np.asarray(path, dtype=np.float64)


def _trend_design(steps: FloatArray, degree: int) -> FloatArray:
    return np.column_stack([steps**d for d in range(degree + 1)])


def _trend_fit(series: FloatArray, degree: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    n = series.shape[0]
    steps = np.arange(n, dtype=np.float64) - (n - 1)  # 0 at the last sample
    design = _trend_design(steps, degree)
    coef, *_ = np.linalg.lstsq(design, series, rcond=None)
    residual = series - design @ coef
    cov = np.linalg.inv(design.T @ design)
    return np.asarray(coef, np.float64), residual, np.asarray(cov, np.float64)


def forecast(
    y: Any,
    *,
    order: int,
    horizon: int,
    band: tuple[float, float],
    level: float = 0.95,
    trend: Trend = "none",
    window: int | None = None,
) -> Forecast:
    """Predict the index ``horizon`` steps ahead and find where it leaves ``band``.

    Parameters
    ----------
    y : array_like, shape (n_times,)
        Index history at equally spaced measurement steps (dimensionless).
    order : int
        AR order ``p``.
    horizon : int
        Steps to forecast (>= 1).
    band : (float, float)
        Tolerance band ``(lower, upper)`` of the index.
    level : float
        Two-sided interval coverage, in (0, 1).
    trend : {"none", "linear", "quadratic"}
        ``"none"``: stationary AR around the sample mean (the thesis's model on
        its stationarity interval). ``"linear"``: a least-squares drift plus AR
        residual, for slowly degrading equipment; ``"quadratic"``: a drift that
        may accelerate (wear), same construction.
    window : int, optional
        Use only the last ``window`` samples (the stationarity interval).

    Returns
    -------
    Forecast

    Raises
    ------
    ValueError
        On fewer than :func:`minimum_history` samples or invalid arguments.
    """
    p = check_positive_int(order, "order")
    steps = check_positive_int(horizon, "horizon")
    lo, hi = check_band(band)
    if not 0.0 < float(level) < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    if trend not in TREND_DEGREE:
        raise ValueError(f"trend must be 'none', 'linear' or 'quadratic', got {trend!r}")
    degree = TREND_DEGREE[trend]
    series = as_vector(y, "y")
    if window is not None:
        series = series[-check_positive_int(window, "window") :]
    need = minimum_history(p, trend)
    if series.shape[0] < need:
        raise ValueError(
            f"not enough history: order={p}, trend={trend!r} need {need} samples, "
            f"got {series.shape[0]}"
        )
    ahead = np.arange(1, steps + 1, dtype=np.float64)
    if degree > 0:
        coef, residual, cov = _trend_fit(series, degree)
        future = _trend_design(ahead, degree)
        base = future @ coef
        slope = float(coef[1])
    else:
        mean = float(series.mean())
        residual = series - mean
        base = np.full(steps, mean)
        slope = 0.0
    a, sigma2 = _fit_ar(residual, p)
    values = base + _ar_path(residual, a, steps)
    var = sigma2 * np.cumsum(psi_weights(a, steps) ** 2)
    if degree > 0:
        gap = max(abs(1.0 - float(a.sum())), MIN_UNIT_ROOT_GAP)
        var = var + (sigma2 / gap**2) * np.einsum("ij,jk,ik->i", future, cov, future)
    std = np.sqrt(var)
    z = float(ndtri(0.5 + float(level) / 2.0))
    outside_now = (values < lo) | (values > hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        prob = np.where(
            std > 0.0,
            ndtr((lo - values) / std) + ndtr((values - hi) / std),
            outside_now.astype(np.float64),
        )
    exits = np.flatnonzero(outside_now)
    return Forecast(
        values=values,
        lower=values - z * std,
        upper=values + z * std,
        std=std,
        exit_probability=np.clip(prob, 0.0, 1.0),
        first_exit=int(exits[0]) + 1 if exits.size else None,
        risk=float(np.clip(prob.max(), 0.0, 1.0)),
        coefficients=a,
        noise_variance=float(sigma2),
        slope=slope,
        band=(lo, hi),
        level=float(level),
    )
