"""Trend-plus-AR forecasts of many index histories at once (array operations over cars).

Shared by the vectorised fleet assessment (:mod:`maintenance.batch`) and the index-band
calibration (:mod:`maintenance.calibration`); the same arithmetic as
:func:`maintenance.forecasting.forecast`, one car per row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from maintenance._checks import FloatArray
from maintenance.bands import INDICATOR_BAND
from maintenance.forecasting import MIN_UNIT_ROOT_GAP, TREND_DEGREE, Trend


def _levinson_batch(r: FloatArray, order: int) -> tuple[FloatArray, FloatArray]:
    """Levinson–Durbin over rows of ``r`` (n, order + 1); zero AR for ``r0 = 0``."""
    n = r.shape[0]
    a = np.zeros((n, order))
    err = r[:, 0].copy()
    live = err > 0.0
    for m in range(order):
        acc = r[:, m + 1] - np.einsum("ij,ij->i", a[:, :m], r[:, m:0:-1])
        k = np.where(live & (err > 0.0), acc / np.where(err > 0.0, err, 1.0), 0.0)
        a[:, :m] = a[:, :m] - k[:, None] * a[:, :m][:, ::-1]
        a[:, m] = k
        err = err * (1.0 - k * k)
    return a, np.where(live, err, 0.0)


def _ar_batch(resid: FloatArray, order: int) -> tuple[FloatArray, FloatArray]:
    """Yule–Walker (biased, demeaned) per row; constant rows get ``a = 0, σ² = 0``."""
    centred = resid - resid.mean(axis=1, keepdims=True)
    n = centred.shape[1]
    r = np.stack(
        [np.einsum("ij,ij->i", centred[:, k:], centred[:, : n - k]) / n for k in range(order + 1)],
        axis=1,
    )
    scale = np.maximum(1.0, np.abs(resid).max(axis=1))
    flat = np.ptp(resid, axis=1) <= 1e-12 * scale
    r[flat] = 0.0
    return _levinson_batch(r, order)


def _paths(resid: FloatArray, a: FloatArray, horizon: int) -> tuple[FloatArray, FloatArray]:
    """AR continuation and ψ-weights, both (n_cars, horizon)."""
    n, p = a.shape
    buf = np.concatenate([resid[:, -p:], np.zeros((n, horizon))], axis=1)
    psi = np.zeros((n, horizon + p))
    psi[:, p] = 1.0
    for h in range(horizon):
        buf[:, p + h] = np.einsum("ij,ij->i", a, buf[:, h : p + h][:, ::-1])
        if h:
            psi[:, p + h] = np.einsum("ij,ij->i", a, psi[:, h : p + h][:, ::-1])
    return buf[:, p:], psi[:, p:]


def forecast_rows(
    y: FloatArray, order: int, horizon: int, trend: Trend
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Trend-plus-AR forecast of every row of ``y`` at once.

    Parameters
    ----------
    y : ndarray, shape (n_cars, n_steps)
        Each car's index history, equally spaced, oldest first (not modified).
    order : int
        AR order of the residual model.
    horizon : int
        Steps ahead to forecast.
    trend : {"none", "linear", "quadratic"}
        Deterministic trend fitted by least squares before the AR model.

    Returns
    -------
    mean, std : ndarray, shape (n_cars, horizon)
        Forecast mean and standard deviation per step ahead.
    a : ndarray, shape (n_cars, order)
        AR coefficients; ``sigma2`` (n_cars,) their noise variance; ``slope`` (n_cars,) the
        trend's slope per step (0 without a trend).
    """
    degree = TREND_DEGREE[trend]
    n = y.shape[1]
    ahead = np.arange(1, horizon + 1, dtype=np.float64)
    if degree > 0:
        steps = np.arange(n, dtype=np.float64) - (n - 1)
        design = np.column_stack([steps**d for d in range(degree + 1)])
        cov = np.linalg.inv(design.T @ design)
        coef = y @ (design @ cov)  # least squares for every car at once
        resid = y - coef @ design.T
        future = np.column_stack([ahead**d for d in range(degree + 1)])
        base = coef @ future.T
        slope = coef[:, 1]
    else:
        mean = y.mean(axis=1, keepdims=True)
        resid = y - mean
        base = np.repeat(mean, horizon, axis=1)
        slope = np.zeros(y.shape[0])
    a, sigma2 = _ar_batch(resid, order)
    path, psi = _paths(resid, a, horizon)
    var = sigma2[:, None] * np.cumsum(psi**2, axis=1)
    if degree > 0:
        gap = np.maximum(np.abs(1.0 - a.sum(axis=1)), MIN_UNIT_ROOT_GAP)
        spread = np.einsum("ij,jk,ik->i", future, cov, future)
        var = var + (sigma2 / gap**2)[:, None] * spread[None, :]
    return base + path, np.sqrt(var), a, sigma2, slope


@dataclass(frozen=True)
class ParameterForecastRules:
    """How each parameter's own forecast of leaving its tolerance band is made.

    A straight line through 40 autocorrelated readings, extended 30 tests ahead, leaves the
    band by chance for a noisy parameter far too often; so a parameter's trend is used only
    when its slope is significant once the residuals' autocorrelation is allowed for, and the
    parameter is otherwise forecast by its AR model around its recent level.

    Attributes
    ----------
    trend_z : float
        The slope must exceed this many standard errors (the OLS error inflated by
        ``(1 + ρ)/(1 − ρ)`` for lag-one autocorrelation ρ of the residuals).
    max_autocorrelation : float
        ρ is capped here (a near-unit-root fit would make every slope insignificant).
    order : int
        AR order of each parameter's residual model.
    """

    trend_z: float = 3.0
    max_autocorrelation: float = 0.95
    order: int = 2


PARAMETER_FORECAST = ParameterForecastRules()


def parameter_exit_rows(
    ind: FloatArray, horizon: int, rules: ParameterForecastRules = PARAMETER_FORECAST
) -> FloatArray:
    """Per row of indicator histories ``ind`` (n_series, n_steps): the probability of being
    outside the indicator band ``[0, 2]`` at the worst of the next ``horizon`` steps."""
    n = ind.shape[1]
    steps = np.arange(n, dtype=np.float64) - (n - 1)
    centred = steps - steps.mean()
    sxx = float(centred @ centred)
    slope = ind @ centred / sxx
    resid = ind - ind.mean(axis=1, keepdims=True) - slope[:, None] * centred[None, :]
    s2 = np.einsum("ij,ij->i", resid, resid) / max(n - 2, 1)
    lag = np.einsum("ij,ij->i", resid[:, 1:], resid[:, :-1])
    rho = np.clip(lag / np.maximum(s2 * max(n - 2, 1), 1e-300), 0.0, rules.max_autocorrelation)
    se = np.sqrt(s2 / sxx * (1.0 + rho) / (1.0 - rho))
    trended = (np.abs(slope) > rules.trend_z * se)[:, None]
    order = min(rules.order, n - 3)
    mean_t, std_t, *_ = forecast_rows(ind, order, horizon, "linear")
    mean_n, std_n, *_ = forecast_rows(ind, order, horizon, "none")
    mean = np.where(trended, mean_t, mean_n)
    std = np.where(trended, std_t, std_n)
    lo, hi = INDICATOR_BAND
    outside = ((mean < lo) | (mean > hi)).astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        prob = np.where(std > 0.0, ndtr((lo - mean) / std) + ndtr((mean - hi) / std), outside)
    return np.asarray(np.clip(prob.max(axis=1), 0.0, 1.0))
