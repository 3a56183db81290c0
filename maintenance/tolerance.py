"""K-of-L failure probability (4.18–4.19) and the index's tolerance band.

Failure criterion: at least ``K`` of the ``L`` predictive parameters outside
their tolerance. With ``A_i`` = "parameter i out of tolerance" and ``S_j`` the
sum of the probabilities of all j-fold intersections,
``P(at least K) = Σ_{j=K..L} (−1)^{j−K}·C(j−1, K−1)·S_j``.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb
from typing import Any

import numpy as np

from maintenance._checks import FloatArray, as_vector, check_positive_int, check_probability


def _check_k(k: Any, n: int) -> int:
    kk = check_positive_int(k, "k")
    if kk > n:
        raise ValueError(f"k={kk} exceeds the number of parameters L={n}")
    return kk


def at_least_k_probability(p: Any, k: int) -> float:
    """Exact ``P(at least k of L independent events)`` (Poisson-binomial tail).

    Parameters
    ----------
    p : array_like, shape (L,)
        Probability of each parameter being out of tolerance, in [0, 1].
    k : int
        ``1 <= k <= L``.

    Returns
    -------
    float
    """
    probs = as_vector(p, "p")
    if np.any((probs < 0.0) | (probs > 1.0)):
        raise ValueError("p must hold probabilities in [0, 1]")
    kk = _check_k(k, probs.shape[0])
    dist = np.zeros(probs.shape[0] + 1)
    dist[0] = 1.0  # dist[j] = P(exactly j out) over the parameters seen so far
    for q in probs:
        dist[1:] = dist[1:] * (1.0 - q) + dist[:-1] * q
        dist[0] *= 1.0 - q
    return float(np.clip(dist[kk:].sum(), 0.0, 1.0))


def at_least_k_inclusion_exclusion(s: Any, k: int) -> float:
    """``P(at least k) = Σ_{j=k..L} (−1)^{j−k}·C(j−1, k−1)·S_j`` (4.18).

    Parameters
    ----------
    s : array_like, shape (L,)
        ``S_1 … S_L``: sums of the probabilities of all j-fold intersections
        (any joint dependence), e.g. from :func:`intersection_sums`.
    k : int
    """
    sums = as_vector(s, "s")
    kk = _check_k(k, sums.shape[0])
    total = sum(
        (-1) ** (j - kk) * comb(j - 1, kk - 1) * float(sums[j - 1])
        for j in range(kk, sums.shape[0] + 1)
    )
    return float(np.clip(total, 0.0, 1.0))


def intersection_sums(outside: Any) -> FloatArray:
    """``S_j`` estimated from joint observations of the out-of-tolerance events.

    Parameters
    ----------
    outside : array_like of bool, shape (n_samples, L)
        ``outside[n, i]`` — parameter i out of tolerance in sample n.

    Returns
    -------
    ndarray, shape (L,)
        ``S_j = mean_n C(m_n, j)`` with ``m_n`` the number out in sample n
        (each sample contributes to every j-subset of its outside parameters).
    """
    flags = np.asarray(outside)
    if flags.ndim != 2 or flags.shape[0] < 1 or flags.shape[1] < 1:
        raise ValueError(f"outside must be 2-D (n_samples, L), got shape {flags.shape}")
    counts = flags.astype(bool).sum(axis=1)
    return np.array(
        [np.mean([comb(int(m), j) for m in counts]) for j in range(1, flags.shape[1] + 1)],
        dtype=np.float64,
    )


def independent_intersection_sums(p: Any) -> FloatArray:
    """``S_j`` = elementary symmetric polynomials of ``p`` (independent events)."""
    probs = as_vector(p, "p")
    e = np.zeros(probs.shape[0] + 1)
    e[0] = 1.0
    for q in probs:
        e[1:] = e[1:] + q * e[:-1]
    return np.asarray(e[1:], dtype=np.float64)


@dataclass(frozen=True)
class ToleranceBand:
    """Tolerance band of the quality index.

    Attributes
    ----------
    lower, upper : float
        Band limits (index units).
    false_alarm : float
        Fraction of serviceable samples outside the band (type I error).
    detection : float or None
        Fraction of faulty samples outside the band (None without faulty data).
    """

    lower: float
    upper: float
    false_alarm: float
    detection: float | None


def tolerance_band(
    serviceable: Any,
    *,
    false_alarm: float,
    faulty: Any = None,
    n_splits: int = 41,
) -> ToleranceBand:
    """Index band with type-I probability ``false_alarm`` and greatest detection.

    The band is ``[q(α_lo), q(1 − α + α_lo)]`` of the serviceable index values
    (empirical quantiles), with ``α_lo ∈ [0, α]`` chosen on a grid to maximise
    the share of ``faulty`` values outside; without faulty data the tails are
    equal.

    Parameters
    ----------
    serviceable : array_like, shape (n,)
        Index values of serviceable objects.
    false_alarm : float
        Allowed type-I probability ``α`` in (0, 1).
    faulty : array_like, shape (m,), optional
        Index values of faulty objects.
    n_splits : int
        Grid size for ``α_lo``.
    """
    good = np.sort(as_vector(serviceable, "serviceable", min_length=2))
    alpha = check_probability(false_alarm, "false_alarm", open_interval=True)
    if faulty is None:
        lo, hi = _sorted_quantile(good, np.array([alpha / 2.0, 1.0 - alpha / 2.0]))
        return ToleranceBand(float(lo), float(hi), _outside(good, lo, hi), None)
    bad = np.sort(as_vector(faulty, "faulty"))
    splits = np.linspace(0.0, alpha, check_positive_int(n_splits, "n_splits", minimum=2))
    lows = _sorted_quantile(good, splits)
    highs = _sorted_quantile(good, 1.0 - (alpha - splits))
    detection = _outside_sorted(bad, lows, highs)
    best = int(np.argmax(detection))  # first maximum: ties keep the smaller lower tail
    lo, hi = float(lows[best]), float(highs[best])
    return ToleranceBand(lo, hi, _outside(good, lo, hi), float(detection[best]))


def _sorted_quantile(values: FloatArray, q: FloatArray) -> FloatArray:
    """Linear-interpolation quantiles (numpy's default) of already sorted ``values``."""
    pos = np.clip(q, 0.0, 1.0) * (values.shape[0] - 1)
    below = np.floor(pos).astype(np.intp)
    above = np.minimum(below + 1, values.shape[0] - 1)
    return np.asarray(values[below] + (values[above] - values[below]) * (pos - below))


def _outside_sorted(values: FloatArray, lo: FloatArray, hi: FloatArray) -> FloatArray:
    """Share of sorted ``values`` below ``lo`` or above ``hi``, for arrays of bands."""
    under = np.searchsorted(values, lo, side="left")
    over = values.shape[0] - np.searchsorted(values, hi, side="right")
    return np.asarray((under + over) / values.shape[0], dtype=np.float64)


def _outside(values: FloatArray, lo: float, hi: float) -> float:
    return float(np.mean((values < lo) | (values > hi)))
