"""Service-facing assessment of a car and the fleet ranking.

:func:`assess_car` turns one car's measurement history into the generalized
quality index, its forecast with interval, the first step out of the index
band, a risk score and plain-language reasons; :func:`rank_fleet` orders the
cars by risk. See :mod:`maintenance.bands` for the indicator scale.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from maintenance._checks import FloatArray, as_vector, check_band, check_positive_int
from maintenance.bands import INDICATOR_BAND, parameter_bands, to_indicators
from maintenance.batch_forecast import parameter_exit_rows
from maintenance.calibration import METHODS, method_weights, quality_index
from maintenance.forecasting import Forecast, Trend, forecast, minimum_history
from maintenance.tolerance import at_least_k_probability

Status = Literal["ok", "not_enough_history"]


@dataclass(frozen=True)
class CarAssessment:
    """One car's predictive-control result.

    Attributes
    ----------
    status : {"ok", "not_enough_history"}
        ``"not_enough_history"``: too few measurements for the AR order; every
        array field is then empty and ``risk`` is None.
    car_id : str or None
    method : str
        Weights method (or ``"given"`` for supplied weights).
    n_measurements : int
    names : tuple of str
        Parameter names.
    times : ndarray, shape (n_times,)
        Measurement times.
    index : ndarray, shape (n_times,)
        Quality-index history (1 = every parameter at its band centre).
    weights : ndarray, shape (n_params,)
    contributions : ndarray, shape (n_params,)
        ``w_i·(x̃_i − 1)`` at the last measurement; they sum to ``index[-1] − 1``.
    index_band : (float, float)
        The index's tolerance band.
    forecast : Forecast or None
        Predicted index, interval and per-step exit probability.
    forecast_times : ndarray, shape (horizon,)
        Times of the forecast steps (last time + step × median interval).
    first_exit : int or None
        First forecast step whose predicted index is outside the band.
    risk : float or None
        Probability in [0, 1] of the index being out of its band within the
        horizon (see :class:`~maintenance.forecasting.Forecast`).
    parameter_exit_probability : ndarray, shape (n_params,)
        Per parameter, probability of being out of tolerance at the worst step of the
        horizon (its own trend, when significant, plus AR noise over the window; see
        :class:`maintenance.batch_forecast.ParameterForecastRules`).
    k_of_l_probability : float or None
        Probability that at least ``k`` parameters are out at the horizon
        (independence assumed).
    reasons : tuple of str
        Plain-language explanation, most important first.
    """

    status: Status
    car_id: str | None
    method: str
    n_measurements: int
    names: tuple[str, ...]
    times: FloatArray
    index: FloatArray
    weights: FloatArray
    contributions: FloatArray
    index_band: tuple[float, float]
    forecast: Forecast | None
    forecast_times: FloatArray
    first_exit: int | None
    risk: float | None
    parameter_exit_probability: FloatArray
    k_of_l_probability: float | None
    reasons: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (arrays as lists) for the service."""
        fc = self.forecast
        return {
            "status": self.status,
            "car_id": self.car_id,
            "method": self.method,
            "n_measurements": self.n_measurements,
            "risk": self.risk,
            "first_exit": self.first_exit,
            "k_of_l_probability": self.k_of_l_probability,
            "index_band": list(self.index_band),
            "times": self.times.tolist(),
            "index": self.index.tolist(),
            "weights": dict(zip(self.names, self.weights.tolist(), strict=True)),
            "contributions": dict(zip(self.names, self.contributions.tolist(), strict=True)),
            "parameter_exit_probability": dict(
                zip(self.names, self.parameter_exit_probability.tolist(), strict=True)
            ),
            "forecast": None
            if fc is None
            else {
                "times": self.forecast_times.tolist(),
                "values": fc.values.tolist(),
                "lower": fc.lower.tolist(),
                "upper": fc.upper.tolist(),
                "level": fc.level,
            },
            "reasons": list(self.reasons),
        }


def _empty(
    car_id: str | None,
    method: str,
    names: tuple[str, ...],
    times: FloatArray,
    band: tuple[float, float],
    reason: str,
) -> CarAssessment:
    nothing = np.zeros(0)
    return CarAssessment(
        status="not_enough_history",
        car_id=car_id,
        method=method,
        n_measurements=int(times.shape[0]),
        names=names,
        times=times,
        index=nothing,
        weights=nothing,
        contributions=nothing,
        index_band=band,
        forecast=None,
        forecast_times=nothing,
        first_exit=None,
        risk=None,
        parameter_exit_probability=nothing,
        k_of_l_probability=None,
        reasons=(reason,),
    )


def _parameter_exit(ind: FloatArray, horizon: int) -> FloatArray:
    """Per-parameter P(out of [0, 2] within the horizon): :func:`parameter_exit_rows`."""
    return parameter_exit_rows(np.ascontiguousarray(ind.T), horizon)


def assessment_reasons(
    names: tuple[str, ...], ind_last: FloatArray, contrib: FloatArray, fc: Forecast,
    band: tuple[float, float], horizon: int, times_ahead: FloatArray,
) -> tuple[str, ...]:  # fmt: skip
    out: list[str] = []
    lo, hi = band
    now = 1.0 + float(contrib.sum())
    if not lo <= now <= hi:
        # Out already: saying "leaves its band 1 test ahead" would understate it.
        out.append(f"already outside its band [{lo:.3f}, {hi:.3f}] now (index {now:.3f})")
    elif fc.first_exit is not None:
        ahead = "the next test" if fc.first_exit == 1 else f"{fc.first_exit} tests ahead"
        out.append(
            f"index forecast leaves its band [{lo:.3f}, {hi:.3f}] at {ahead} "
            f"(t = {times_ahead[fc.first_exit - 1]:g}); risk {fc.risk:.0%} within {horizon} tests"
        )
    else:
        out.append(
            f"index forecast stays inside [{lo:.3f}, {hi:.3f}] for the next {horizon} tests; "
            f"risk {fc.risk:.0%}"
        )
    out.append(f"index now {now:.3f}, drifting {fc.slope:+.4f} per test")
    order = np.argsort(-np.abs(contrib))
    top = [i for i in order[:3] if abs(contrib[i]) > 0.0]
    if top:
        parts = ", ".join(f"{names[i]} ({contrib[i]:+.3f})" for i in top)
        out.append(f"largest contributions to the index deviation: {parts}")
    outside = [names[i] for i in np.flatnonzero((ind_last < 0.0) | (ind_last > 2.0))]
    if outside:
        out.append(f"parameters already out of tolerance: {', '.join(outside)}")
    return tuple(out)


def assess_car(
    history: Any,
    *,
    times: Any,
    band: Any,
    order: int = 2,
    horizon: int = 30,
    weights_method: str = "prediction",
    weights: Any = None,
    index_band: tuple[float, float] = INDICATOR_BAND,
    window: int | None = 40,
    trend: Trend = "linear",
    level: float = 0.95,
    k: int = 1,
    names: Sequence[str] | None = None,
    car_id: str | None = None,
) -> CarAssessment:
    """Assess one car: index, forecast, first exit, risk and reasons.

    Parameters
    ----------
    history : array_like, shape (n_times, n_params)
        Measurements, one row per measurement time, parameter units.
    times : array_like, shape (n_times,)
        Strictly increasing measurement times (any unit, e.g. days); the AR
        model treats the rows as equally spaced steps.
    band : (lower, upper) or array_like, shape (n_params, 2)
        Tolerance band per parameter, ``nominal ± tolerance`` (build with
        :func:`maintenance.bands.bands_from_nominal`); one pair applies to all.
    order : int
        AR order of the index forecast.
    horizon : int
        Forecast steps.
    weights_method : str
        ``prediction`` (4.16, default), ``inverse_variance`` (4.17), ``rayleigh``
        or ``equal``, computed from this car's history; ``fisher`` needs fleet
        labels, so pass its ``weights`` (see :func:`maintenance.calibrate_fleet`).
    weights : array_like, shape (n_params,), optional
        Fleet weights on the indicators; overrides ``weights_method``.
    index_band : (float, float)
        Index band; default ``(0, 2)`` (weighted deviation of one tolerance
        half-width); use a calibrated band from :func:`maintenance.calibrate_fleet`.
    window : int or None
        Last samples used for the trend/AR fit (stationarity interval).
    trend : {"linear", "none"}
        Index model (see :func:`maintenance.forecast`).
    level : float
        Interval coverage.
    k : int
        K of the K-of-L criterion for ``k_of_l_probability``.
    names : sequence of str, optional
        Parameter names (default ``p0, p1, …``).
    car_id : str, optional

    Returns
    -------
    CarAssessment
        ``status="not_enough_history"`` instead of an exception when there are
        too few measurements.
    """
    data = np.asarray(history, dtype=np.float64)
    if data.ndim != 2 or data.shape[1] < 1:
        raise ValueError(f"history must be 2-D (n_times, n_params), got shape {data.shape}")
    if not np.all(np.isfinite(data)):
        raise ValueError("history contains NaN or infinite values")
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    if t.shape[0] != data.shape[0] or np.any(np.diff(t) <= 0.0) or not np.all(np.isfinite(t)):
        raise ValueError("times must be finite, strictly increasing, one per history row")
    p, steps = check_positive_int(order, "order"), check_positive_int(horizon, "horizon")
    ib = check_band(index_band, "index_band")
    label = names if names is not None else [f"p{i}" for i in range(data.shape[1])]
    labels = tuple(str(n) for n in label)
    if len(labels) != data.shape[1]:
        raise ValueError(f"names has {len(labels)} entries for {data.shape[1]} parameters")
    method = "given" if weights is not None else weights_method
    need = max(minimum_history(p, trend), p + 3)
    if data.shape[0] < need:
        msg = (
            f"not enough history: {data.shape[0]} measurements, need at least {need} for order {p}"
        )
        return _empty(car_id, method, labels, t, ib, msg)
    ind = to_indicators(data, parameter_bands(band, data.shape[1]))  # validates band
    w, note = _weights(ind, weights, weights_method, p)
    y = quality_index(ind, w)
    fc = forecast(y, order=p, horizon=steps, band=ib, level=level, trend=trend, window=window)
    dt = float(np.median(np.diff(t))) if t.shape[0] > 1 else 1.0
    ahead = t[-1] + dt * np.arange(1, steps + 1)
    contrib = w * (ind[-1] - 1.0)
    recent = ind[-window:] if window is not None else ind
    p_out = _parameter_exit(recent, steps)
    kk = min(check_positive_int(k, "k"), data.shape[1])
    reasons = assessment_reasons(labels, ind[-1], contrib, fc, ib, steps, ahead)
    return CarAssessment(
        status="ok",
        car_id=car_id,
        method=method if note is None else "equal",
        n_measurements=int(data.shape[0]),
        names=labels,
        times=t,
        index=y,
        weights=w,
        contributions=contrib,
        index_band=ib,
        forecast=fc,
        forecast_times=ahead,
        first_exit=fc.first_exit,
        risk=fc.risk,
        parameter_exit_probability=p_out,
        k_of_l_probability=at_least_k_probability(p_out, kk),
        reasons=reasons if note is None else (*reasons, note),
    )


def _weights(
    ind: FloatArray, weights: Any, method: str, order: int
) -> tuple[FloatArray, str | None]:
    """Weights and, when the method cannot work on this history, the reason for equal weights."""
    if weights is not None:
        w = as_vector(weights, "weights")
        if w.shape[0] != ind.shape[1]:
            raise ValueError(f"weights has {w.shape[0]} values for {ind.shape[1]} parameters")
        return w, None
    if method not in METHODS:
        raise ValueError(f"unknown weights method {method!r}; choose one of {', '.join(METHODS)}")
    if method == "fisher":
        return method_weights(method, ind, order=order), None  # raises: needs fleet labels
    try:
        return method_weights(method, ind, order=order), None
    except (ValueError, np.linalg.LinAlgError) as exc:  # e.g. a history that never varies
        note = f"{method} weights unavailable for this history ({exc}); equal weights used"
        return method_weights("equal", ind), note


def rank_fleet(
    assessments: Iterable[CarAssessment] | Mapping[str, CarAssessment],
) -> list[CarAssessment]:
    """Cars ordered by risk (highest first), then earliest exit.

    Cars without enough history come last (their risk is unknown, not low).
    A mapping's keys fill in missing ``car_id``.
    """
    if isinstance(assessments, Mapping):
        items = [
            a if a.car_id is not None else replace(a, car_id=str(key))
            for key, a in assessments.items()
        ]
    else:
        items = list(assessments)

    def key(a: CarAssessment) -> tuple[int, float, float]:
        if a.status != "ok" or a.risk is None:
            return (1, 0.0, 0.0)
        exit_step = float(a.first_exit) if a.first_exit is not None else float("inf")
        return (0, -a.risk, exit_step)

    return sorted(items, key=key)
