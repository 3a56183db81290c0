"""Linear prediction of the quality index (eq. 4.3): Yule–Walker by Levinson–Durbin.

The index ``y_n`` is predicted from its ``p`` previous values,
``ŷ_n = Σ_{k=1..p} a_k·y_{n−k}`` (mean removed), with ``a`` solving the
Yule–Walker equations ``Σ_k a_k·R(i−k) = R(i)``, ``i = 1…p`` (eq. 4.8), where ``R``
is the biased (``1/N``) autocorrelation of the mean-removed index on its
stationarity interval. The Toeplitz system is solved by the Levinson–Durbin
recursion in O(p²).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.signal import lfilter

from maintenance._checks import FloatArray, as_vector, check_positive_int


def autocorrelation(y: Any, max_lag: int, *, demean: bool = True) -> FloatArray:
    """Biased autocorrelation ``R(k) = (1/N)·Σ_n y_n·y_{n+k}``, ``k = 0…max_lag``.

    Parameters
    ----------
    y : array_like, shape (n_times,)
        The series (index values, dimensionless).
    max_lag : int
        Largest lag, ``0 <= max_lag < n_times``.
    demean : bool
        Remove the sample mean first (the stationary part of the index).

    Returns
    -------
    ndarray, shape (max_lag + 1,)
    """
    series = as_vector(y, "y")
    lag = check_positive_int(max_lag, "max_lag", minimum=0)
    if lag >= series.shape[0]:
        raise ValueError(f"max_lag={lag} needs more than {lag} samples, got {series.shape[0]}")
    if demean:
        series = series - series.mean()
    n = series.shape[0]
    full = np.correlate(series, series, mode="full")[n - 1 : n + lag]
    return np.asarray(full / n, dtype=np.float64)


def levinson_durbin(r: Any, order: int) -> tuple[FloatArray, float, FloatArray]:
    """Solve the Yule–Walker equations for autocorrelation ``r`` by Levinson–Durbin.

    Parameters
    ----------
    r : array_like, shape (>= order + 1,)
        Autocorrelation ``R(0), R(1), …``; ``R(0) > 0``.
    order : int
        Prediction order ``p >= 1``.

    Returns
    -------
    a : ndarray, shape (order,)
        Prediction coefficients ``a_1 … a_p`` (``ŷ_n = Σ a_k y_{n−k}``).
    sigma2 : float
        Prediction error variance ``R(0) − Σ a_k R(k)``.
    reflection : ndarray, shape (order,)
        Reflection (partial autocorrelation) coefficients; ``|k_m| <= 1`` for a
        valid (positive semi-definite) autocorrelation.
    """
    p = check_positive_int(order, "order")
    rr = as_vector(r, "r", min_length=p + 1)
    if rr[0] <= 0.0:
        raise ValueError("R(0) must be positive: the series is constant")
    a = np.zeros(p, dtype=np.float64)
    reflection = np.zeros(p, dtype=np.float64)
    err = float(rr[0])
    for m in range(p):
        acc = rr[m + 1] - float(np.dot(a[:m], rr[m:0:-1]))
        k = acc / err if err > 0.0 else 0.0
        previous = a[:m].copy()
        a[:m] = previous - k * previous[::-1]
        a[m] = k
        reflection[m] = k
        err *= 1.0 - k * k
    return a, float(err), reflection


def yule_walker(y: Any, order: int) -> tuple[FloatArray, float]:
    """AR coefficients and noise variance of ``y`` by Yule–Walker (eq. 4.8).

    Uses the biased autocorrelation of the mean-removed series, so it agrees
    with ``statsmodels.regression.linear_model.yule_walker(y, order,
    method="mle")`` (which returns ``(a, sigma)``; here ``sigma2 = sigma²``).

    Parameters
    ----------
    y : array_like, shape (n_times,)
        Index history, ``n_times > order``.
    order : int
        Prediction order ``p >= 1``.

    Returns
    -------
    a : ndarray, shape (order,)
        ``a_1 … a_p`` with ``ŷ_n − ȳ = Σ a_k (y_{n−k} − ȳ)``.
    sigma2 : float
        Variance of the one-step prediction error (the AR noise).

    Raises
    ------
    ValueError
        If ``y`` has ``<= order`` samples, is constant, or is not finite.
    """
    p = check_positive_int(order, "order")
    series = as_vector(y, "y")
    if series.shape[0] <= p:
        raise ValueError(f"order={p} needs more than {p} samples, got {series.shape[0]}")
    r = autocorrelation(series, p)
    if r[0] <= 1e-300:
        raise ValueError("y is constant: the AR model is undefined")
    a, sigma2, _ = levinson_durbin(r, p)
    return a, sigma2


def psi_weights(a: Any, n: int) -> FloatArray:
    """First ``n`` ψ-weights of the AR model (``ψ_0 = 1``, ``ψ_j = Σ_k a_k ψ_{j−k}``).

    The ``h``-step prediction error variance is ``σ²·Σ_{j<h} ψ_j²``.

    Parameters
    ----------
    a : array_like, shape (p,)
        AR coefficients.
    n : int
        Number of weights (>= 1).

    Returns
    -------
    ndarray, shape (n,)
    """
    coef = as_vector(a, "a")
    count = check_positive_int(n, "n")
    impulse = np.zeros(count)
    impulse[0] = 1.0
    return np.asarray(lfilter([1.0], np.r_[1.0, -coef], impulse), dtype=np.float64)
