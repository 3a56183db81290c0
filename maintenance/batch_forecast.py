"""Trend-plus-AR forecasts of many index histories at once (array operations over cars).

Shared by the vectorised fleet assessment (:mod:`maintenance.batch`) and the index-band
calibration (:mod:`maintenance.calibration`); the same arithmetic as
:func:`maintenance.forecasting.forecast`, one car per row.
"""

from __future__ import annotations

import numpy as np

from maintenance._checks import FloatArray
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
