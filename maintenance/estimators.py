"""scikit-learn style estimators: the quality index and its AR forecaster.

``fit`` returns ``self``; learned attributes end in ``_``; constructor
arguments are stored unchanged (so ``get_params``/``clone`` work).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin

from maintenance._checks import FloatArray, as_matrix, as_vector
from maintenance.forecasting import Forecast, Trend, forecast, minimum_history
from maintenance.linear_prediction import yule_walker
from maintenance.weights import (
    equal_weights,
    fisher_weights,
    inverse_variance_weights,
    prediction_weights,
    rayleigh_weights,
)


class QualityIndex(TransformerMixin, BaseEstimator):  # type: ignore[misc]
    """Generalized quality index ``y = Wᵀ·X`` (eq. 4.2) with learned weights.

    Parameters
    ----------
    method : {"prediction", "fisher", "rayleigh", "inverse_variance", "equal"}
    order : int
        AR order (``prediction`` weights and ``ar_coefficients_``).
    centres : array_like, shape (n_params,), optional
        Tolerance-band centres ``X0`` (default: ones, i.e. indicator data).
    window : int or array_like, optional
        Sliding window for ``prediction`` (see :func:`maintenance.weights.history_window`).

    Attributes
    ----------
    weights_ : ndarray, shape (n_params,)
    n_features_in_ : int
    ar_coefficients_ : ndarray, shape (order,)
        Yule–Walker fit of the training index (zeros if it is constant).
    noise_variance_ : float
    """

    def __init__(
        self,
        method: str = "prediction",
        *,
        order: int = 2,
        centres: Any = None,
        window: Any = None,
    ) -> None:
        self.method = method
        self.order = order
        self.centres = centres
        self.window = window

    def fit(self, X: Any, y: Any = None) -> QualityIndex:
        """Learn the weights from ``X`` (n_samples, n_params), time-ordered rows.

        ``y`` (bool, shape (n_samples,)) marks faulty samples: required for
        ``fisher``; ``inverse_variance`` then uses the serviceable rows only.
        """
        data = as_matrix(X, "X", min_rows=2)
        x0 = np.ones(data.shape[1]) if self.centres is None else as_vector(self.centres, "centres")
        faulty = None if y is None else np.asarray(y, dtype=bool).reshape(-1)
        if faulty is not None and faulty.shape[0] != data.shape[0]:
            raise ValueError(f"y has {faulty.shape[0]} labels for {data.shape[0]} samples")
        good = data if faulty is None else data[~faulty]
        if self.method == "prediction":
            w = prediction_weights(data, x0, order=self.order, window=self.window)
        elif self.method == "inverse_variance":
            w = inverse_variance_weights(good, x0)
        elif self.method == "equal":
            w = equal_weights(x0)
        elif self.method == "rayleigh":
            w = rayleigh_weights(data)
        elif self.method == "fisher":
            if faulty is None:
                raise ValueError("method='fisher' needs y marking the faulty samples")
            w = fisher_weights(data[~faulty], data[faulty])
        else:
            raise ValueError(f"unknown method {self.method!r}")
        self.weights_ = w
        self.n_features_in_ = data.shape[1]
        index = data @ w
        try:
            self.ar_coefficients_, self.noise_variance_ = yule_walker(index, self.order)
        except ValueError:
            self.ar_coefficients_, self.noise_variance_ = np.zeros(self.order), 0.0
        return self

    def transform(self, X: Any) -> FloatArray:
        """Index of each row, shape (n_samples, 1)."""
        if not hasattr(self, "weights_"):
            raise ValueError("QualityIndex is not fitted: call fit first")
        data = as_matrix(X, "X")
        if data.shape[1] != self.n_features_in_:
            raise ValueError(f"X has {data.shape[1]} parameters, fitted on {self.n_features_in_}")
        return np.asarray((data @ self.weights_)[:, None], dtype=np.float64)


class ARForecaster(BaseEstimator):  # type: ignore[misc]
    """AR(p) forecaster of an index series (optionally with a trend).

    Parameters
    ----------
    order : int
    trend : {"none", "linear", "quadratic"}
    window : int, optional
        Fit on the last ``window`` samples only.
    level : float
        Interval coverage.

    Attributes
    ----------
    history_ : ndarray, shape (n_times,)
    coef_ : ndarray, shape (order,)
        AR coefficients (of the detrended series when ``trend`` is set).
    noise_variance_ : float
    """

    def __init__(
        self,
        order: int = 2,
        *,
        trend: Trend = "none",
        window: int | None = None,
        level: float = 0.95,
    ) -> None:
        self.order = order
        self.trend = trend
        self.window = window
        self.level = level

    def fit(self, y: Any, X: Any = None) -> ARForecaster:
        """Store the series and fit the AR part (``X`` is ignored)."""
        series = as_vector(y, "y")
        if series.shape[0] < minimum_history(self.order, self.trend):
            raise ValueError(
                f"not enough history: {series.shape[0]} samples for order {self.order}"
            )
        self.history_ = series
        fc = forecast(series, order=self.order, horizon=1, band=(-1e300, 1e300),
                      trend=self.trend, window=self.window, level=self.level)  # fmt: skip
        self.coef_ = fc.coefficients
        self.noise_variance_ = fc.noise_variance
        return self

    def forecast(self, horizon: int, *, band: tuple[float, float] = (-1e300, 1e300)) -> Forecast:
        """Full :class:`~maintenance.forecasting.Forecast` ``horizon`` steps ahead."""
        if not hasattr(self, "history_"):
            raise ValueError("ARForecaster is not fitted: call fit first")
        return forecast(self.history_, order=self.order, horizon=horizon, band=band,
                        trend=self.trend, window=self.window, level=self.level)  # fmt: skip

    def predict(self, horizon: int) -> FloatArray:
        """Predicted values for steps ``1 … horizon``, shape (horizon,)."""
        return self.forecast(horizon).values
