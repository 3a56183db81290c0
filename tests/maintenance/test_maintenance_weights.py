"""Rayleigh, Fisher, inverse-variance and prediction-optimal weights."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.decomposition import PCA
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

from maintenance import (
    fisher_weights,
    inverse_variance_weights,
    lagged_correlations,
    levinson_durbin,
    prediction_error_matrix,
    prediction_weights,
    rayleigh_weights,
)

X0 = np.array([3.0, 48.0, 2.4, 10.0])
SIGMA = np.array([0.1, 2.0, 0.05, 0.5])


def _correlated(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    mix = np.array([[1, 0.5, 0, 0.2], [0, 1, 0.3, 0], [0, 0, 1, 0.4], [0.1, 0, 0, 1]])
    return rng.normal(size=(n, 4)) @ mix * SIGMA + X0


def test_rayleigh_is_top_principal_axis() -> None:
    X = _correlated(500, 0)
    w = rayleigh_weights(X)
    pc = PCA(n_components=1).fit(X).components_[0]
    assert abs(float(w @ pc)) == pytest.approx(1.0, abs=1e-10)
    assert np.linalg.norm(w) == pytest.approx(1.0)
    assert w[np.argmax(np.abs(w))] > 0
    scatter = (X - X.mean(0)).T @ (X - X.mean(0))
    rng = np.random.default_rng(1)
    for _ in range(50):  # no other unit vector has a larger Rayleigh quotient
        v = rng.normal(size=4)
        v /= np.linalg.norm(v)
        assert v @ scatter @ v <= w @ scatter @ w + 1e-9


def test_fisher_agrees_with_lda_direction() -> None:
    rng = np.random.default_rng(2)
    good = _correlated(300, 3)
    bad = _correlated(200, 4) + rng.normal(0, 1, 4) * SIGMA * 2
    w = fisher_weights(good, bad)
    X = np.vstack([good, bad])
    y = np.r_[np.ones(len(good)), np.zeros(len(bad))]  # serviceable = positive class
    for solver in ("svd", "lsqr", "eigen"):
        coef = LinearDiscriminantAnalysis(solver=solver).fit(X, y).coef_[0]
        assert float(w @ coef / np.linalg.norm(coef)) == pytest.approx(1.0, abs=1e-8)
    assert np.linalg.norm(w) == pytest.approx(1.0)


def test_fisher_rejects_singular_or_mismatched() -> None:
    good = np.ones((5, 3))
    with pytest.raises(ValueError, match="singular"):
        fisher_weights(good, good + 1.0)
    with pytest.raises(ValueError, match="parameters"):
        fisher_weights(np.ones((5, 3)), np.ones((5, 2)))


def test_inverse_variance_is_eq_4_17() -> None:
    X = _correlated(1000, 5)
    w = inverse_variance_weights(X, X0)
    var = np.mean((X - X0) ** 2, axis=0)
    np.testing.assert_allclose(w, (X0 / var) / np.sum(X0**2 / var))
    assert float(w @ X0) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="never deviate"):
        inverse_variance_weights(np.tile(X0, (5, 1)), X0)


def test_prediction_weights_reduce_to_4_17_for_white_independent_parameters() -> None:
    rng = np.random.default_rng(6)
    X = X0 + rng.normal(size=(40000, 4)) * SIGMA
    w = prediction_weights(X, X0, order=2)
    expected = (X0 / SIGMA**2) / np.sum(X0**2 / SIGMA**2)
    np.testing.assert_allclose(w, expected, rtol=0.03)
    assert float(w @ X0) == pytest.approx(1.0, abs=1e-12)
    assert np.argmax(w * SIGMA) == np.argmax(X0 / SIGMA)  # most stable relative to x0 ranks first


def _drifting_history(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = 400
    X = np.empty((n, 4))
    X[:, 0] = 0.02 * np.cumsum(rng.normal(size=n))  # slow drift: predictable
    X[:, 1:] = rng.normal(size=(n, 3)) * [0.3, 0.2, 0.4]
    return X + 1.0


def test_prediction_weights_are_a_fixed_point_and_constrained_minimum() -> None:
    X = _drifting_history(7)
    x0 = np.ones(4)
    w = prediction_weights(X, x0, order=2, tol=1e-13)
    R = lagged_correlations(X - x0, 2)
    a, _, _ = levinson_durbin(np.einsum("i,kij,j->k", w, R, w), 2)
    r_sigma = prediction_error_matrix(R, a)
    np.testing.assert_allclose(
        w, np.linalg.solve(r_sigma, x0) / (x0 @ np.linalg.solve(r_sigma, x0)), atol=1e-8
    )
    rng = np.random.default_rng(8)
    for _ in range(50):  # perturbations keeping Wᵀx0 = 1 never lower E[e²]
        d = rng.normal(size=4)
        d -= d.mean()
        assert (w + 0.01 * d) @ r_sigma @ (w + 0.01 * d) >= w @ r_sigma @ w
    assert float(w @ x0) == pytest.approx(1.0)


def test_prediction_error_matrix_matches_empirical_error() -> None:
    X = _drifting_history(9)
    D = X - 1.0
    a = np.array([0.7, 0.2])
    w = np.array([0.4, 0.3, 0.2, 0.1])
    e = D[2:] @ w - a[0] * (D[1:-1] @ w) - a[1] * (D[:-2] @ w)
    got = w @ prediction_error_matrix(lagged_correlations(D, 2), a) @ w
    assert got == pytest.approx(np.mean(e**2), rel=0.03)


def test_prediction_weights_window_and_errors() -> None:
    X = _drifting_history(10)
    w = prediction_weights(X, np.ones(4), order=1, window=100)
    assert float(w.sum()) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="not enough history"):
        prediction_weights(X[:3], np.ones(4), order=2)
    with pytest.raises(ValueError, match="all zeros"):
        prediction_weights(X, np.zeros(4), order=2)
    with pytest.raises(ValueError, match="x0 has 3"):
        prediction_weights(X, np.ones(3), order=2)


def test_prediction_weights_pool_ragged_histories() -> None:
    X = _drifting_history(11)
    pooled = prediction_weights([X[:150], X[150:]], np.ones(4), order=2)
    assert float(pooled.sum()) == pytest.approx(1.0)
    np.testing.assert_allclose(pooled, prediction_weights(X, np.ones(4), order=2), atol=0.05)


def test_weights_do_not_modify_inputs() -> None:
    X = _correlated(100, 12)
    copy = X.copy()
    rayleigh_weights(X)
    inverse_variance_weights(X, X0)
    prediction_weights(X, X0, order=1)
    np.testing.assert_array_equal(X, copy)


def test_history_window_is_a_hann_taper_over_the_last_samples() -> None:
    from maintenance.weights import history_window

    w = history_window(10, 5)
    assert np.all(w[:5] == 0.0) and w[7] == pytest.approx(1.0)
    np.testing.assert_allclose(w[5:], w[5:][::-1])  # falls from centre to edges
    np.testing.assert_allclose(history_window(4, [1.0, 0.5]), [0, 0, 1.0, 0.5])
    with pytest.raises(ValueError, match="non-negative"):
        history_window(4, [-1.0, 1.0])
