"""Vectorized fleet assessment: the same results as :func:`assess_car`, many cars at once.

The scheduled forecast job assesses thousands of cars with shared fleet
weights. With equal-length histories the trend design matrix, its inverse
and the trend variance are the same for every car, and the Levinson–Durbin,
ψ-weight and AR recursions run over all cars as array operations, so the
per-car cost is mostly building the result objects.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.special import ndtr, ndtri

from maintenance._checks import FloatArray, as_vector, check_band, check_positive_int
from maintenance.bands import INDICATOR_BAND, parameter_bands, to_indicators
from maintenance.batch_forecast import forecast_rows, parameter_exit_rows
from maintenance.calibration import quality_index
from maintenance.fleet import CarAssessment, assess_car, assessment_reasons
from maintenance.forecasting import TREND_DEGREE, Forecast, Trend, minimum_history


def _parameter_exit_batch(ind: FloatArray, horizon: int) -> FloatArray:
    """Per car and parameter, P(out of [0, 2] within the horizon): :func:`parameter_exit_rows`."""
    n_cars, n_steps, n_params = ind.shape
    rows = np.ascontiguousarray(ind.transpose(0, 2, 1)).reshape(n_cars * n_params, n_steps)
    return parameter_exit_rows(rows, horizon).reshape(n_cars, n_params)


def _at_least_k_batch(p: FloatArray, k: int) -> FloatArray:
    dist = np.zeros((p.shape[0], p.shape[1] + 1))
    dist[:, 0] = 1.0
    for j in range(p.shape[1]):
        q = p[:, j : j + 1]
        dist[:, 1:] = dist[:, 1:] * (1.0 - q) + dist[:, :-1] * q
        dist[:, 0] *= 1.0 - q[:, 0]
    return np.asarray(np.clip(dist[:, k:].sum(axis=1), 0.0, 1.0))


def assess_fleet(
    histories: Any,
    *,
    times: Any,
    band: Any,
    weights: Any,
    index_band: tuple[float, float] = INDICATOR_BAND,
    order: int = 2,
    horizon: int = 30,
    window: int | None = 40,
    trend: Trend = "linear",
    level: float = 0.95,
    k: int = 1,
    names: Sequence[str] | None = None,
    car_ids: Sequence[str] | None = None,
) -> list[CarAssessment]:
    """Assess many cars with shared fleet weights; equals :func:`assess_car` per car.

    Parameters
    ----------
    histories : array_like, shape (n_cars, n_times, n_params)
        Equal-length measurement histories (parameter units), rows in time order.
    times : array_like, shape (n_times,)
        Common measurement times (strictly increasing).
    weights : array_like, shape (n_params,)
        Fleet weights on the indicators (e.g. ``calibrate_fleet(...).weights``).
    band, index_band, order, horizon, window, trend, level, k, names
        As in :func:`maintenance.fleet.assess_car`.
    car_ids : sequence of str, optional
        One id per car.

    Returns
    -------
    list of CarAssessment, in input order (rank them with ``rank_fleet``).
    """
    data = np.asarray(histories, dtype=np.float64)
    if data.ndim != 3 or data.shape[0] < 1:
        raise ValueError(f"histories must be 3-D (n_cars, n_times, n_params), got {data.shape}")
    ids: list[str | None] = [None] * data.shape[0] if car_ids is None else [str(c) for c in car_ids]
    if len(ids) != data.shape[0]:
        raise ValueError(f"car_ids has {len(ids)} entries for {data.shape[0]} cars")
    if trend not in TREND_DEGREE:
        raise ValueError(f"trend must be 'none', 'linear' or 'quadratic', got {trend!r}")
    p, steps = check_positive_int(order, "order"), check_positive_int(horizon, "horizon")
    need = max(minimum_history(p, trend), p + 3)
    if data.shape[1] < need or not np.all(np.isfinite(data)):
        # rare paths (short or broken histories) keep the per-car messages
        return [
            assess_car(h, times=times, band=band, weights=weights, index_band=index_band,
                       order=p, horizon=steps, window=window, trend=trend,
                       level=level, k=k, names=names, car_id=c)
            for h, c in zip(data, ids, strict=True)
        ]  # fmt: skip
    t = as_vector(times, "times")
    if t.shape[0] != data.shape[1] or np.any(np.diff(t) <= 0.0):
        raise ValueError("times must be strictly increasing, one per history row")
    w = as_vector(weights, "weights")
    if w.shape[0] != data.shape[2]:
        raise ValueError(f"weights has {w.shape[0]} values for {data.shape[2]} parameters")
    ib = check_band(index_band, "index_band")
    if not 0.0 < float(level) < 1.0:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    labels = tuple(str(x) for x in (names or [f"p{i}" for i in range(data.shape[2])]))
    if len(labels) != data.shape[2]:
        raise ValueError(f"names has {len(labels)} entries for {data.shape[2]} parameters")
    ind = to_indicators(data, parameter_bands(band, data.shape[2]))
    y = quality_index(ind, w)
    recent = slice(-window, None) if window is not None else slice(None)
    mean, std, a, sigma2, slope = forecast_rows(y[:, recent], p, steps, trend)
    lo, hi = ib
    outside = (mean < lo) | (mean > hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        prob = np.where(std > 0.0, ndtr((lo - mean) / std) + ndtr((mean - hi) / std), outside * 1.0)
    prob = np.clip(prob, 0.0, 1.0)
    z = float(ndtri(0.5 + float(level) / 2.0))
    p_out = _parameter_exit_batch(ind[:, recent], steps)
    kk = min(check_positive_int(k, "k"), data.shape[2])
    k_of_l = _at_least_k_batch(p_out, kk)
    dt = float(np.median(np.diff(t))) if t.shape[0] > 1 else 1.0
    ahead = t[-1] + dt * np.arange(1, steps + 1)
    contrib = w * (ind[:, -1] - 1.0)
    out = []
    for c in range(data.shape[0]):
        exits = np.flatnonzero(outside[c])
        fc = Forecast(
            values=mean[c], lower=mean[c] - z * std[c], upper=mean[c] + z * std[c], std=std[c],
            exit_probability=prob[c], first_exit=int(exits[0]) + 1 if exits.size else None,
            risk=float(prob[c].max()), coefficients=a[c], noise_variance=float(sigma2[c]),
            slope=float(slope[c]), band=ib, level=float(level),
        )  # fmt: skip
        out.append(
            CarAssessment(
                status="ok",
                car_id=ids[c],
                method="given",
                n_measurements=int(data.shape[1]),
                names=labels,
                times=t,
                index=y[c],
                weights=w,
                contributions=contrib[c],
                index_band=ib,
                forecast=fc,
                forecast_times=ahead,
                first_exit=fc.first_exit,
                risk=fc.risk,
                parameter_exit_probability=p_out[c],
                k_of_l_probability=float(k_of_l[c]),
                reasons=assessment_reasons(labels, ind[c, -1], contrib[c], fc, ib, steps, ahead),
            )  # fmt: skip
        )
    return out
