"""Index weights by method, and their fleet calibration with a tolerance band.

All weights act on the indicators of :mod:`maintenance.bands` (``x0 = 1``); the
index is ``y = 1 + Wᵀ(x̃ − 1)`` (``= Wᵀx̃`` when ``Wᵀx0 = 1``). ``prediction``,
``inverse_variance`` and ``equal`` satisfy ``Wᵀx0 = 1`` (thesis 4.11);
``rayleigh`` and ``fisher`` carry no such constraint and are scaled to
``Σ|w_i| = 1``, so for all methods one tolerance half-width of weighted
deviation moves the index by at most 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from maintenance._checks import FloatArray, check_positive_int, check_probability
from maintenance.bands import to_indicators
from maintenance.batch_forecast import forecast_rows
from maintenance.forecasting import minimum_history
from maintenance.tolerance import ToleranceBand, tolerance_band
from maintenance.weights import (
    equal_weights,
    fisher_weights,
    inverse_variance_weights,
    prediction_weights,
    rayleigh_weights,
)

Method = Literal["prediction", "fisher", "rayleigh", "inverse_variance", "equal"]
METHODS: tuple[str, ...] = ("prediction", "fisher", "rayleigh", "inverse_variance", "equal")
FLAG_RISK = 0.5  # a car is flagged when its risk reaches this


def _l1(w: FloatArray) -> FloatArray:
    total = float(np.abs(w).sum())
    if total == 0.0:
        raise ValueError("all weights are zero")
    return np.asarray(w / total, dtype=np.float64)


def method_weights(
    method: str,
    indicators: Any,
    *,
    order: int = 2,
    faulty: Any = None,
    window: Any = None,
) -> FloatArray:
    """Weights of ``method`` on indicator data (``x0 = 1``).

    Parameters
    ----------
    method : {"prediction", "fisher", "rayleigh", "inverse_variance", "equal"}
    indicators : array_like, shape (n_times, n_params) or (n_cars, n_times, n_params)
        Indicator history (a 3-D stack pools the cars; only ``prediction``
        uses the time order).
    order : int
        AR order for ``prediction``.
    faulty : array_like of bool, shape (n_times,) or (n_cars, n_times), optional
        Faulty-state labels: required by ``fisher``; other methods use only the
        serviceable samples when given (``prediction``: the cars never found
        faulty, since it needs unbroken series).
    window : int or array_like, optional
        Sliding window for ``prediction``.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    data = np.asarray(indicators, dtype=np.float64)
    if data.ndim not in (2, 3):
        raise ValueError(f"indicators must be 2-D or 3-D, got shape {data.shape}")
    ones = np.ones(data.shape[-1])
    rows = data.reshape(-1, data.shape[-1])
    labels = None if faulty is None else np.asarray(faulty, dtype=bool).reshape(-1)
    if labels is not None and labels.shape[0] != rows.shape[0]:
        raise ValueError("faulty must label every sample of indicators")
    good = rows if labels is None else rows[~labels]
    if method == "prediction":
        if labels is not None and data.ndim == 3:
            # moments of the serviceable type: cars with a faulty state would let
            # their wear level dominate R(k) (the series must stay contiguous)
            clean = ~np.asarray(faulty, dtype=bool).reshape(data.shape[:2]).any(axis=1)
            data = data[clean] if clean.any() else data
        return prediction_weights(data, ones, order=order, window=window)
    if method == "inverse_variance":
        return inverse_variance_weights(good, ones)
    if method == "equal":
        return equal_weights(ones)
    if method == "rayleigh":
        return _l1(rayleigh_weights(rows))
    if method == "fisher":
        if labels is None or not labels.any() or labels.all():
            raise ValueError(
                "fisher weights need serviceable and faulty examples: pass faulty= labels "
                "(or compute them once for the fleet and pass weights=)"
            )
        return _l1(fisher_weights(rows[~labels], rows[labels]))
    raise ValueError(f"unknown weights method {method!r}; choose one of {', '.join(METHODS)}")


def quality_index(indicators: Any, weights: Any) -> FloatArray:
    """Index ``y = 1 + Wᵀ(x̃ − 1)`` over the last axis; shape ``indicators.shape[:-1]``."""
    data = np.asarray(indicators, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1 or w.shape[0] != data.shape[-1]:
        raise ValueError(f"weights must have shape ({data.shape[-1]},), got {w.shape}")
    return np.asarray(1.0 + (data - 1.0) @ w, dtype=np.float64)


@dataclass(frozen=True)
class FleetCalibration:
    """Fleet-wide weights and index band for one method.

    Attributes
    ----------
    method : str
    weights : ndarray, shape (n_params,)
        Weights on the indicators.
    band : ToleranceBand
        Index band with the requested false-alarm rate and best detection.
    """

    method: str
    weights: FloatArray
    band: ToleranceBand

    @property
    def index_band(self) -> tuple[float, float]:
        """``(lower, upper)`` of the index band."""
        return (self.band.lower, self.band.upper)


def _car_forecasts(
    index: FloatArray, cut: int, *, order: int, horizon: int, window: int | None
) -> tuple[FloatArray, FloatArray]:
    """Forecast mean and std (n_cars, horizon) of each car's index from its first ``cut`` steps."""
    start = 0 if window is None else max(cut - check_positive_int(window, "window"), 0)
    means, stds, *_ = forecast_rows(index[:, start:cut], order, horizon, "linear")
    return means, stds


def _flag_cost(
    means: FloatArray, stds: FloatArray, truth: Any, cand: ToleranceBand, miss_cost: float
) -> float:
    std = np.maximum(stds, 1e-12)
    prob = ndtr((cand.lower - means) / std) + ndtr((means - cand.upper) / std)
    flagged = prob.max(axis=1) >= FLAG_RISK
    return float(np.sum(flagged & ~truth) + miss_cost * np.sum(~flagged & truth))


def calibrate_fleet(
    histories: Any,
    *,
    band: Any,
    faulty: NDArray[np.bool_] | Any,
    method: str = "prediction",
    order: int = 2,
    false_alarm: float | None = None,
    horizon: int = 30,
    window: int | None = 40,
    miss_cost: float = 1.5,
) -> FleetCalibration:
    """Fit ``method``'s weights on a reference fleet's records and set the index band.

    Parameters
    ----------
    histories : array_like, shape (n_cars, n_times, n_params)
        Recorded measurements (parameter units) of a reference fleet, long
        enough to see what happened ``horizon`` steps after a cut-off.
    band : (lower, upper) or array_like, shape (n_params, 2)
        Per-parameter tolerance bands.
    faulty : array_like of bool, shape (n_cars, n_times)
        Whether each recorded state was found faulty (out of tolerance).
    method : str
        One of :data:`METHODS`.
    order : int
        AR order (``prediction`` weights and the forecasts).
    false_alarm : float, optional
        Type-I probability ``α`` of the index band on serviceable states (the
        thesis's rule, :func:`maintenance.tolerance_band`). ``None`` (default)
        chooses ``α`` on a log grid from 1e-4 to 0.2: each car is cut
        ``horizon`` steps before the end of its record, forecast as
        :func:`maintenance.fleet.assess_car` does, and the band with the least
        cost of wrong flags (flagged at risk >= 0.5 vs. found faulty within the
        horizon) wins — the band edge then sits where cars that do leave
        tolerance actually are.
    horizon, window : int
        Forecast horizon and trend window used for ``false_alarm=None``
        (use the same in :func:`maintenance.fleet.assess_car`).
    miss_cost : float
        Cost of a missed failing car relative to a needless inspection (>0).
    """
    data = np.asarray(histories, dtype=np.float64)
    if data.ndim != 3:
        raise ValueError(f"histories must be 3-D (n_cars, n_times, n_params), got {data.shape}")
    labels = np.asarray(faulty, dtype=bool)
    if labels.shape != data.shape[:2]:
        raise ValueError(f"faulty must have shape {data.shape[:2]}, got {labels.shape}")
    if labels.all():
        raise ValueError("faulty marks every state: the band needs serviceable states")
    indicators = to_indicators(data, band)
    w = method_weights(method, indicators, order=order, faulty=labels)
    index = quality_index(indicators, w)
    good, bad = index[~labels], (index[labels] if labels.any() else None)
    if false_alarm is not None:
        alpha = check_probability(false_alarm, "false_alarm", open_interval=True)
        return FleetCalibration(method, w, tolerance_band(good, false_alarm=alpha, faulty=bad))
    h = check_positive_int(horizon, "horizon")
    cut = data.shape[1] - h
    if bad is None or cut < minimum_history(order, "linear"):
        raise ValueError("false_alarm=None needs faulty states and records longer than horizon")
    means, stds = _car_forecasts(index, cut, order=order, horizon=h, window=window)
    truth = labels[:, cut:].any(axis=1)
    if not float(miss_cost) > 0.0:
        raise ValueError(f"miss_cost must be positive, got {miss_cost!r}")
    best: tuple[float, ToleranceBand] | None = None
    for alpha in np.geomspace(1e-4, 0.2, 100):
        cand = tolerance_band(good, false_alarm=float(alpha), faulty=bad)
        errors = _flag_cost(means, stds, truth, cand, float(miss_cost))
        if best is None or errors < best[0]:
            best = (errors, cand)
    assert best is not None
    return FleetCalibration(method, w, best[1])
