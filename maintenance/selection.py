"""Choosing the predictive parameters (4.2): derivative norm and entropy.

- Derivative norm ``‖x_i‖ = |x_i| + |dx_i/dt| + |d²x_i/dt²| + …`` averaged over
  the history: a parameter that is far from its centre *or moving* matters for
  forecasting; those under a threshold are dropped.
- Entropy of a Gaussian parameter ``½·log2(2πe·σ²)``: the most stable
  (low-entropy) parameters are the most telling.

Both are scale-dependent: pass ``scale`` (e.g. the tolerance half-widths) so
parameters in different units compare fairly.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from maintenance._checks import FloatArray, as_matrix, as_vector, check_positive_int


def _scaled(X: Any, scale: Any) -> FloatArray:
    data = as_matrix(X, "X", min_rows=2)
    if scale is None:
        return data
    s = as_vector(scale, "scale")
    if s.shape[0] != data.shape[1] or np.any(s <= 0.0):
        raise ValueError(f"scale must hold {data.shape[1]} positive values")
    return data / s


def derivative_norm(X: Any, *, times: Any, n_derivatives: int = 2, scale: Any = None) -> FloatArray:
    """Mean over the history of ``|x_i| + |dx_i/dt| + … + |dⁿx_i/dtⁿ|``.

    Parameters
    ----------
    X : array_like, shape (n_times, n_params)
        Parameter values (typically deviations from the tolerance centres).
    times : array_like, shape (n_times,)
        Strictly increasing measurement times (derivatives are per this unit).
    n_derivatives : int
        Highest derivative order (>= 0).
    scale : array_like, shape (n_params,), optional
        Divide each parameter by this first (e.g. tolerance half-widths).

    Returns
    -------
    ndarray, shape (n_params,)
    """
    data = _scaled(X, scale)
    t = as_vector(times, "times")
    if t.shape[0] != data.shape[0] or np.any(np.diff(t) <= 0.0):
        raise ValueError("times must be strictly increasing with one value per row of X")
    order = check_positive_int(n_derivatives, "n_derivatives", minimum=0)
    if order >= data.shape[0]:
        raise ValueError(f"n_derivatives={order} needs more than {order} samples")
    total = np.abs(data).mean(axis=0)
    current = data
    for _ in range(order):
        current = np.gradient(current, t, axis=0)
        total = total + np.abs(current).mean(axis=0)
    return np.asarray(total, dtype=np.float64)


def select_by_derivative_norm(
    X: Any, *, times: Any, threshold: float, n_derivatives: int = 2, scale: Any = None
) -> NDArray[np.intp]:
    """Indices of parameters with derivative norm >= ``threshold``, largest first."""
    norm = derivative_norm(X, times=times, n_derivatives=n_derivatives, scale=scale)
    order = np.argsort(-norm, kind="stable")
    return np.asarray(order[norm[order] >= float(threshold)], dtype=np.intp)


def gaussian_entropy(X: Any, *, scale: Any = None) -> FloatArray:
    """Entropy ``½·log2(2πe·σ_i²)`` (bits) of each parameter taken as Gaussian.

    Parameters
    ----------
    X : array_like, shape (n_samples, n_params)
    scale : array_like, shape (n_params,), optional
        Divide each parameter by this first.

    Returns
    -------
    ndarray, shape (n_params,); ``-inf`` for a constant parameter.
    """
    var = _scaled(X, scale).var(axis=0, ddof=1)
    with np.errstate(divide="ignore"):
        return np.asarray(0.5 * np.log2(2.0 * np.pi * np.e * var), dtype=np.float64)


def select_by_entropy(
    X: Any, *, n_keep: int | None = None, threshold: float | None = None, scale: Any = None
) -> NDArray[np.intp]:
    """Indices of the lowest-entropy parameters, most stable first.

    Give ``n_keep`` (keep that many) or ``threshold`` (keep entropy <= it, bits).
    Constant parameters carry no information and are never kept.
    """
    if (n_keep is None) == (threshold is None):
        raise ValueError("give exactly one of n_keep or threshold")
    entropy = gaussian_entropy(X, scale=scale)
    order = np.argsort(entropy, kind="stable")
    order = order[np.isfinite(entropy[order])]
    if n_keep is not None:
        return np.asarray(order[: check_positive_int(n_keep, "n_keep")], dtype=np.intp)
    return np.asarray(order[entropy[order] <= float(threshold)], dtype=np.intp)  # type: ignore[arg-type]


def select_by_weights(weights: Any, *, threshold: float) -> NDArray[np.intp]:
    """Predictive set: parameters with ``|w_i| >= threshold``, largest ``|w_i|`` first (4.2)."""
    w = np.abs(as_vector(weights, "weights"))
    order = np.argsort(-w, kind="stable")
    return np.asarray(order[w[order] >= float(threshold)], dtype=np.intp)
