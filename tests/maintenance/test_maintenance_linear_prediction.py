"""Yule–Walker, Levinson–Durbin, ψ-weights and the index forecast."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.linalg import solve_toeplitz
from scipy.signal import lfilter
from statsmodels.regression.linear_model import yule_walker as sm_yule_walker
from statsmodels.tsa.arima_process import arma2ma

from maintenance import autocorrelation, forecast, levinson_durbin, psi_weights, yule_walker


def _ar_series(coef: list[float], n: int, seed: int, mean: float = 0.0) -> np.ndarray:
    e = np.random.default_rng(seed).normal(size=n + 200)
    y = lfilter([1.0], np.r_[1.0, -np.asarray(coef)], e)  # y_t = Σ a_k y_{t−k} + e_t
    return np.asarray(y[200:] + mean)


def _statsmodels(y: np.ndarray, order: int) -> tuple[np.ndarray, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rho, sigma = sm_yule_walker(y, order, method="mle")
    return np.asarray(rho), float(sigma) ** 2


@pytest.mark.parametrize("order", [1, 2, 3, 5, 8])
@pytest.mark.parametrize(
    ("coef", "mean", "seed"),
    [([0.6, -0.3], 5.0, 0), ([0.95], -2.0, 1), ([0.0], 0.0, 2), ([1.2, -0.5, 0.1], 100.0, 3)],
)
def test_yule_walker_matches_statsmodels_mle(
    order: int, coef: list[float], mean: float, seed: int
) -> None:
    y = _ar_series(coef, 300, seed, mean)
    a, sigma2 = yule_walker(y, order)
    rho, sm_sigma2 = _statsmodels(y, order)
    np.testing.assert_allclose(a, rho, rtol=0, atol=1e-8)
    assert sigma2 == pytest.approx(sm_sigma2, abs=1e-8)


def test_yule_walker_short_random_walk_matches_statsmodels() -> None:
    y = np.cumsum(np.random.default_rng(7).normal(size=40))
    a, sigma2 = yule_walker(y, 4)
    rho, sm_sigma2 = _statsmodels(y, 4)
    np.testing.assert_allclose(a, rho, atol=1e-8)
    assert sigma2 == pytest.approx(sm_sigma2, abs=1e-8)


def test_yule_walker_recovers_ar2_coefficients() -> None:
    a, sigma2 = yule_walker(_ar_series([0.6, -0.3], 20000, 11), 2)
    np.testing.assert_allclose(a, [0.6, -0.3], atol=0.02)
    assert sigma2 == pytest.approx(1.0, rel=0.03)


def test_levinson_durbin_matches_toeplitz_solve() -> None:
    r = autocorrelation(_ar_series([0.5, 0.2], 500, 4), 6)
    a, sigma2, reflection = levinson_durbin(r, 6)
    np.testing.assert_allclose(a, solve_toeplitz(r[:6], r[1:7]), atol=1e-12)
    assert sigma2 == pytest.approx(r[0] - a @ r[1:7], abs=1e-12)
    assert np.all(np.abs(reflection) <= 1.0)


def test_psi_weights_match_statsmodels_arma2ma() -> None:
    a = np.array([0.6, -0.3, 0.1])
    np.testing.assert_allclose(psi_weights(a, 12), arma2ma(np.r_[1.0, -a], [1.0], lags=12))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((np.arange(3.0), 3), "needs more than 3 samples"),
        ((np.ones(50), 2), "constant"),
        ((np.arange(10.0), 0), "order must be >= 1"),
        ((np.r_[1.0, np.nan, 2.0, 3.0], 1), "NaN"),
        ((np.ones((4, 2)), 1), "1-D"),
    ],
)
def test_yule_walker_rejects_bad_input(args: tuple[object, int], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        yule_walker(*args)


def test_forecast_ar1_follows_closed_form() -> None:
    y = _ar_series([0.8], 400, 5, mean=10.0)
    fc = forecast(y, order=1, horizon=10, band=(0.0, 20.0))
    (a,), sigma2 = yule_walker(y, 1)
    steps = np.arange(1, 11)
    np.testing.assert_allclose(fc.values, y.mean() + a**steps * (y[-1] - y.mean()), atol=1e-10)
    var = sigma2 * np.cumsum(a ** (2 * (steps - 1)))
    np.testing.assert_allclose(fc.std, np.sqrt(var), rtol=1e-10)
    np.testing.assert_allclose(fc.upper - fc.values, 1.959963985 * np.sqrt(var), rtol=1e-8)
    assert fc.first_exit is None and fc.risk < 0.01


def test_forecast_interval_coverage_on_ar2() -> None:
    """95 % intervals cover ~95 % of true futures (400 independent series)."""
    hits = []
    for seed in range(400):
        path = _ar_series([0.6, -0.3], 230, seed)
        fc = forecast(path[:200], order=2, horizon=5, band=(-50.0, 50.0))
        hits.append((fc.lower[4] <= path[204]) & (path[204] <= fc.upper[4]))
    assert np.mean(hits) == pytest.approx(0.95, abs=0.03)


def test_forecast_linear_trend_finds_band_exit() -> None:
    rng = np.random.default_rng(3)
    y = 1.0 + 0.005 * np.arange(200) + rng.normal(0.0, 0.01, 200)
    fc = forecast(y, order=2, horizon=40, band=(0.0, 2.1), trend="linear", window=60)
    # last level ≈ 1.995, 0.005 per step → crosses 2.1 after ≈ 21 steps
    assert fc.slope == pytest.approx(0.005, rel=0.05)
    assert fc.first_exit is not None and abs(fc.first_exit - 21) <= 2
    assert fc.exit_probability[-1] > 0.99 and fc.risk > 0.99
    assert np.all(np.diff(fc.std) >= 0)


def test_forecast_not_enough_history_and_bad_band() -> None:
    with pytest.raises(ValueError, match="not enough history"):
        forecast([1.0, 2.0, 3.0], order=2, horizon=5, band=(0, 3), trend="linear")
    with pytest.raises(ValueError, match="lower < upper"):
        forecast(np.arange(20.0), order=1, horizon=5, band=(3, 1))
    with pytest.raises(ValueError, match="trend"):
        forecast(np.arange(20.0), order=1, horizon=5, band=(0, 1), trend="cubic")  # type: ignore[arg-type]


def test_forecast_constant_series_is_certain() -> None:
    fc = forecast(np.full(30, 1.5), order=2, horizon=4, band=(0.0, 1.0))
    np.testing.assert_allclose(fc.values, 1.5)
    assert fc.first_exit == 1 and fc.risk == 1.0 and np.all(fc.std == 0.0)


def test_forecast_does_not_modify_input() -> None:
    y = _ar_series([0.5], 100, 9)
    copy = y.copy()
    forecast(y, order=2, horizon=3, band=(-9, 9), trend="linear")
    np.testing.assert_array_equal(y, copy)
