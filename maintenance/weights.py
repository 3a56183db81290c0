"""Weight vectors ``W`` of the generalized quality index ``y_n = Wᵀ·X_n`` (eq. 4.2).

- :func:`rayleigh_weights` — top eigenvector of the objects' scatter ``B``;
- :func:`fisher_weights` — Fisher discriminant ``W ∝ B_W⁻¹(X̄1 − X̄2)``;
- :func:`inverse_variance_weights` — case (4.17), ``w_i ∝ x0_i/σ_i²``;
- :func:`prediction_weights` — the thesis's prediction-optimal weights (4.16),
  ``W = R_Σ⁻¹X0 / (X0ᵀR_Σ⁻¹X0)``, alternating with the Yule–Walker fit.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from maintenance._checks import FloatArray, as_matrix, as_vector, check_positive_int
from maintenance.linear_prediction import levinson_durbin


def _fix_sign(w: FloatArray) -> FloatArray:
    """Make the largest-magnitude component positive (an eigenvector's sign is arbitrary)."""
    return w if w[int(np.argmax(np.abs(w)))] >= 0.0 else -w


def rayleigh_weights(X: Any) -> FloatArray:
    """Unit weight vector maximising the Rayleigh quotient ``WᵀBW / WᵀW``.

    Parameters
    ----------
    X : array_like, shape (n_objects, n_params)
        One row per tested object (car), parameters in consistent units.

    Returns
    -------
    ndarray, shape (n_params,)
        Eigenvector of ``B = Σ_l (X_l − X̄)(X_l − X̄)ᵀ`` with the largest eigenvalue,
        ``‖W‖ = 1``, largest-magnitude component positive.
    """
    data = as_matrix(X, "X", min_rows=2)
    centred = data - data.mean(axis=0)
    _, vectors = np.linalg.eigh(centred.T @ centred)
    return _fix_sign(np.asarray(vectors[:, -1], dtype=np.float64))


def fisher_weights(X_serviceable: Any, X_faulty: Any) -> FloatArray:
    """Fisher discriminant direction ``W ∝ B_W⁻¹(X̄1 − X̄2)``, ``‖W‖ = 1``.

    Parameters
    ----------
    X_serviceable : array_like, shape (n1, n_params)
        Objects of class 1 (serviceable).
    X_faulty : array_like, shape (n2, n_params)
        Objects of class 2 (faulty).

    Returns
    -------
    ndarray, shape (n_params,)
        Points from the faulty mean towards the serviceable mean, so serviceable
        objects score higher (same direction as scikit-learn's
        ``LinearDiscriminantAnalysis`` coefficient with serviceable as the
        positive class).
    """
    good = as_matrix(X_serviceable, "X_serviceable", min_rows=2)
    bad = as_matrix(X_faulty, "X_faulty", min_rows=2)
    if good.shape[1] != bad.shape[1]:
        raise ValueError(f"X_serviceable has {good.shape[1]} parameters, X_faulty {bad.shape[1]}")
    g, b = good - good.mean(axis=0), bad - bad.mean(axis=0)
    within = g.T @ g + b.T @ b
    diff = good.mean(axis=0) - bad.mean(axis=0)
    try:
        w = np.linalg.solve(within, diff)
    except np.linalg.LinAlgError as exc:
        raise ValueError(
            "within-class scatter B_W is singular: need more objects than parameters "
            "and no constant parameter"
        ) from exc
    norm = float(np.linalg.norm(w))
    if norm == 0.0 or not np.isfinite(norm):
        raise ValueError("the class means coincide: no discriminating direction")
    return np.asarray(w / norm, dtype=np.float64)


def _check_centres(x0: Any, n_params: int) -> FloatArray:
    centres = as_vector(x0, "x0")
    if centres.shape[0] != n_params:
        raise ValueError(f"x0 has {centres.shape[0]} values but X has {n_params} parameters")
    if not np.any(centres):
        raise ValueError("x0 must not be all zeros (the constraint is Wᵀ·x0 = 1)")
    return centres


def inverse_variance_weights(X: Any, x0: Any) -> FloatArray:
    """Case (4.17): ``w_i = (x0_i/σ_i²) / Σ_j (x0_j²/σ_j²)``, so ``Wᵀx0 = 1``.

    Parameters
    ----------
    X : array_like, shape (n_samples, n_params)
        Measurements of the parameters.
    x0 : array_like, shape (n_params,)
        Tolerance-band centres.

    Returns
    -------
    ndarray, shape (n_params,)

    Notes
    -----
    ``σ_i²`` is the mean square deviation from the centre, ``mean((x_i − x0_i)²)``,
    the same moment :func:`prediction_weights` uses, so both agree for white,
    independent parameters.
    """
    data = as_matrix(X, "X", min_rows=2)
    centres = _check_centres(x0, data.shape[1])
    var = np.mean((data - centres) ** 2, axis=0)
    if np.any(var <= 0.0):
        raise ValueError(f"parameters {np.flatnonzero(var <= 0.0).tolist()} never deviate")
    score = centres / var
    return np.asarray(score / float(score @ centres), dtype=np.float64)


def equal_weights(x0: Any) -> FloatArray:
    """Equal weights ``w_i = 1 / Σ_j x0_j`` (``Wᵀx0 = 1``), the naive baseline."""
    centres = as_vector(x0, "x0")
    total = float(centres.sum())
    if total == 0.0:
        raise ValueError("equal weights need Σ x0 ≠ 0")
    return np.full(centres.shape[0], 1.0 / total)


def history_window(length: int, window: Any) -> FloatArray:
    """Sample weights ``w_n`` for the sliding window (4.20) over the last samples.

    ``window`` is an int ``N`` (a Hann window over the last ``N`` samples,
    falling from its centre to its edges as the thesis asks) or explicit
    non-negative weights applied to the last ``len(window)`` samples.
    Returns shape (length,), zero outside the window.
    """
    out = np.zeros(length, dtype=np.float64)
    if isinstance(window, int | np.integer) and not isinstance(window, bool):
        n = min(check_positive_int(window, "window", minimum=3), length)
        out[length - n :] = np.hanning(n + 2)[1:-1]
        return out
    shape = as_vector(window, "window")
    if shape.shape[0] > length or np.any(shape < 0.0) or not np.any(shape):
        raise ValueError("window weights must be non-negative, not all 0, and fit the history")
    out[length - shape.shape[0] :] = shape
    return out


def lagged_correlations(D: Any, max_lag: int) -> FloatArray:
    """``R(k) = (1/N)·Σ_n D_n·D_{n−k}ᵀ`` for ``k = 0…max_lag`` (biased, not demeaned).

    Parameters
    ----------
    D : array_like, shape (n_times, n_params) or (n_cars, n_times, n_params), or list
        Deviations from the tolerance centres; a 3-D stack is pooled over cars,
        a list of 2-D arrays (histories of different lengths) is pooled
        weighting each by its length.
    max_lag : int

    Returns
    -------
    ndarray, shape (max_lag + 1, n_params, n_params)
    """
    lag = check_positive_int(max_lag, "max_lag", minimum=0)
    if isinstance(D, list | tuple):
        parts = [np.asarray(d, dtype=np.float64) for d in D]
        if not parts or any(d.ndim != 2 or d.shape[1] != parts[0].shape[1] for d in parts):
            raise ValueError("a list D must hold 2-D arrays with the same number of parameters")
        # pool histories of different lengths (e.g. engines) weighting by length
        pooled = np.zeros((lag + 1, parts[0].shape[1], parts[0].shape[1]))
        for d in parts:
            pooled += lagged_correlations(d, lag) * d.shape[0]
        return np.asarray(pooled / sum(d.shape[0] for d in parts), dtype=np.float64)
    data = np.asarray(D, dtype=np.float64)
    if data.ndim == 2:
        data = data[None]
    if data.ndim != 3 or not np.all(np.isfinite(data)):
        raise ValueError(
            "D must be finite, shape (n_times, n_params) or (n_cars, n_times, n_params)"
        )
    n = data.shape[1]
    if n <= lag:
        raise ValueError(f"max_lag={lag} needs more than {lag} samples, got {n}")
    out = np.empty((lag + 1, data.shape[2], data.shape[2]), dtype=np.float64)
    for k in range(lag + 1):
        out[k] = np.einsum("cti,ctj->ij", data[:, k:], data[:, : n - k]) / (n * data.shape[0])
    return out


def prediction_error_matrix(R: Any, a: Any) -> FloatArray:
    """``R_Σ = R(0) − Σ_k a_k(R(k) + R(k)ᵀ) + Σ_i Σ_j a_i a_j R(i−j)`` (eq. 4.10).

    ``R`` has shape (p + 1, M, M); ``R(−k) = R(k)ᵀ``. Returns shape (M, M).
    """
    corr = np.asarray(R, dtype=np.float64)
    coef = as_vector(a, "a")
    p = coef.shape[0]
    if corr.ndim != 3 or corr.shape[0] < p + 1:
        raise ValueError(f"R must have shape (>= {p + 1}, M, M), got {corr.shape}")
    out = corr[0].copy()
    for k in range(1, p + 1):
        out -= coef[k - 1] * (corr[k] + corr[k].T)
    for i in range(1, p + 1):
        for j in range(1, p + 1):
            lagged = corr[i - j] if i >= j else corr[j - i].T
            out += coef[i - 1] * coef[j - 1] * lagged
    return np.asarray(0.5 * (out + out.T), dtype=np.float64)


def _constrained_minimum(r_sigma: FloatArray, centres: FloatArray) -> FloatArray:
    scale = float(np.trace(r_sigma)) / r_sigma.shape[0]
    if scale <= 0.0:
        raise ValueError("the history never deviates from x0: R_Σ is zero")
    ridge = r_sigma + 1e-10 * scale * np.eye(r_sigma.shape[0])  # guards exact collinearity
    solved = np.linalg.solve(ridge, centres)
    return np.asarray(solved / float(centres @ solved), dtype=np.float64)


def prediction_weights(
    X_history: Any,
    x0: Any,
    *,
    order: int,
    window: Any = None,
    max_iter: int = 100,
    tol: float = 1e-8,
) -> FloatArray:
    """Prediction-optimal weights (4.16): ``W = R_Σ⁻¹X0 / (X0ᵀR_Σ⁻¹X0)``.

    ``R(k)`` are estimated on the deviations ``X_n − X0`` (optionally tapered
    by the sliding window (4.20)). The AR coefficients depend on ``W``, so the
    fit alternates: AR step — Levinson–Durbin on the index autocorrelation
    ``r(k) = WᵀR(k)W``; weight step — (4.16) with ``R_Σ(a)``. Both steps lower the
    same ``E[e²] = WᵀR_Σ(a)W`` on ``Wᵀx0 = 1``, so it converges. It starts from
    the persistence predictor ``a = (1, 0, …)``: starting from ``a = 0`` would
    penalise every parameter whose mean sits off-centre and can lock the fit
    into ignoring a slow drift, which is what forecasting must see.

    Parameters
    ----------
    X_history : array_like, shape (n_times, n_params) or (n_cars, n_times, n_params)
        Measurement history (a 3-D stack pools the moments over cars; a list of
        2-D arrays pools histories of different lengths).
    x0 : array_like, shape (n_params,)
        Tolerance-band centres; the result satisfies ``Wᵀx0 = 1``.
    order : int
        AR order ``p``; the history needs more than ``p + 1`` samples.
    window : int or array_like, optional
        Sliding window (see :func:`history_window`).
    max_iter : int
        Alternation limit.
    tol : float
        Stop when ``‖ΔW‖ <= tol·‖W‖``.

    Returns
    -------
    ndarray, shape (n_params,)
    """
    p = check_positive_int(order, "order")
    parts = list(X_history) if isinstance(X_history, list | tuple) else [X_history]
    arrays = [np.asarray(x, dtype=np.float64) for x in parts]
    if any(a.ndim not in (2, 3) for a in arrays):
        raise ValueError("X_history must be 2-D, 3-D or a list of 2-D arrays")
    centres = _check_centres(x0, arrays[0].shape[-1])
    shortest = min(a.shape[-2] for a in arrays)
    if shortest <= p + 1:
        raise ValueError(
            f"not enough history: order={p} needs more than {p + 1} samples, got {shortest}"
        )
    deviations = []
    for a in arrays:
        dev = a - centres
        if window is not None:
            dev = dev * history_window(a.shape[-2], window)[:, None]
        deviations.append(dev)
    R = lagged_correlations(deviations if len(deviations) > 1 else deviations[0], p)
    a = np.zeros(p)
    a[0] = 1.0
    w = _constrained_minimum(prediction_error_matrix(R, a), centres)
    for _ in range(check_positive_int(max_iter, "max_iter")):
        r = np.einsum("i,kij,j->k", w, R, w)
        if r[0] <= 0.0:
            break
        a, _, _ = levinson_durbin(r, p)
        new = _constrained_minimum(prediction_error_matrix(R, a), centres)
        done = float(np.linalg.norm(new - w)) <= tol * float(np.linalg.norm(new))
        w = new
        if done:
            break
    return w
