"""scikit-learn conventions of QualityIndex and ARForecaster."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from maintenance import ARForecaster, QualityIndex, fisher_weights, forecast, prediction_weights


def _data(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = 1.0 + rng.normal(size=(300, 3)) * [0.05, 0.2, 0.1]
    faulty = np.zeros(300, dtype=bool)
    faulty[250:] = True
    X[250:, 0] += 0.3
    return X, faulty


@pytest.mark.parametrize(
    "method", ["prediction", "inverse_variance", "rayleigh", "equal", "fisher"]
)
def test_quality_index_follows_sklearn_conventions(method: str) -> None:
    X, faulty = _data()
    est = QualityIndex(method, order=2)
    assert est.fit(X, faulty) is est
    assert est.weights_.shape == (3,) and est.n_features_in_ == 3
    assert est.ar_coefficients_.shape == (2,)
    assert est.transform(X).shape == (300, 1)
    twin = clone(est)
    assert twin.get_params() == est.get_params() and not hasattr(twin, "weights_")


def test_quality_index_weights_match_functions() -> None:
    X, faulty = _data(1)
    np.testing.assert_allclose(
        QualityIndex("prediction", order=2).fit(X).weights_,
        prediction_weights(X, np.ones(3), order=2),
    )
    np.testing.assert_allclose(
        QualityIndex("fisher").fit(X, faulty).weights_, fisher_weights(X[~faulty], X[faulty])
    )


def test_quality_index_errors() -> None:
    X, _ = _data()
    with pytest.raises(ValueError, match="not fitted"):
        QualityIndex().transform(X)
    with pytest.raises(ValueError, match="faulty"):
        QualityIndex("fisher").fit(X)
    with pytest.raises(ValueError, match="unknown method"):
        QualityIndex("magic").fit(X)
    with pytest.raises(ValueError, match="parameters"):
        QualityIndex().fit(X).transform(X[:, :2])


def test_ar_forecaster_matches_forecast() -> None:
    y = np.cumsum(np.random.default_rng(3).normal(size=120)) * 0.01 + 1.0
    est = ARForecaster(2, trend="linear", window=60)
    assert est.fit(y) is est
    ref = forecast(y, order=2, horizon=10, band=(0.0, 2.0), trend="linear", window=60)
    np.testing.assert_allclose(est.predict(10), ref.values)
    np.testing.assert_allclose(est.coef_, ref.coefficients)
    assert est.forecast(10, band=(0.0, 2.0)).first_exit == ref.first_exit
    with pytest.raises(ValueError, match="not fitted"):
        ARForecaster().predict(3)
    with pytest.raises(ValueError, match="not enough history"):
        ARForecaster(3).fit([1.0, 2.0, 3.0])
