"""Predictive maintenance: the generalized quality index and its forecast (thesis 002, ch. 4).

Pure algorithms (numpy, scipy, scikit-learn); no database or web code.

Service wiring
--------------
Per car, call::

    from maintenance.fleet import assess_car, rank_fleet

    a = assess_car(history, times=times, band=bands, order=2, horizon=30,
                   weights_method="prediction", names=param_names, car_id="0117")
    a.to_dict()          # JSON for GET /api/v1/cars/{id}/forecast
    ranked = rank_fleet(assessments)   # GET /api/v1/maintenance/fleet, highest risk first

For the scheduled job over the whole fleet (equal-length histories, shared
fleet weights) use the vectorized, result-identical
``maintenance.batch.assess_fleet(histories (n_cars, n_times, n_params), *,
times, band, weights, index_band, ..., names, car_ids) -> list[CarAssessment]``
(measured 6,700–17,000 cars/s of computation on one core, depending on machine
load, vs 1,400–2,000 for ``assess_car``).

- ``history``: NDArray (n_times, n_params) of measurements in each parameter's
  unit, rows in time order; ``times``: (n_times,) strictly increasing.
- ``band``: per-parameter tolerance bands, shape (n_params, 2) of
  ``(lower, upper)`` — build ``nominal ± tolerance`` with
  :func:`maintenance.bands.bands_from_nominal` — or one pair for all.
  Measurements become indicators ``1 + (x − centre)/half_width``: 1 at the
  band centre, 0 and 2 at its limits; the index of a perfect car is 1.
- Result :class:`maintenance.fleet.CarAssessment`: index history, weights,
  per-parameter contributions, forecast with interval, first step out of the
  index band, ``risk`` in [0, 1] (probability of being out of the band within
  the horizon), the K-of-L probability and plain-language ``reasons``. Too few
  measurements give ``status="not_enough_history"`` (no exception).
- Best results: calibrate once on the depot's records (cars' histories with
  the states found faulty) and pass the fleet weights and band to every car::

      cal = calibrate_fleet(histories, band=bands, faulty=faulty, method="prediction")
      assess_car(h, times=t, band=bands, weights=cal.weights, index_band=cal.index_band)

  Without calibration the index band is ``(0, 2)``: the weighted deviation
  reaches one tolerance half-width (conservative).
- ``maintenance.simulate.simulate_fleet`` generates a demo fleet (names, bands,
  histories, truth); ``maintenance.simulate.demo_calibration()`` gives fleet
  weights and an index band for such fleets (about 1 s).

Public API
----------
``yule_walker(y, order)``, ``forecast(y, *, order, horizon, band)``,
``rayleigh_weights(X)``, ``fisher_weights(X_serviceable, X_faulty)``,
``inverse_variance_weights(X, x0)``, ``prediction_weights(X_history, x0, *, order, window=None)``,
``at_least_k_probability(p, k)``, ``at_least_k_inclusion_exclusion(s, k)``,
``intersection_sums(outside)``, ``tolerance_band(serviceable, *, false_alarm, faulty=None)``,
``derivative_norm``/``select_by_derivative_norm``, ``gaussian_entropy``/``select_by_entropy``,
``select_by_weights``, ``economic_effect``/``discount_factors`` (4.4),
estimators ``QualityIndex`` and ``ARForecaster``, ``calibrate_fleet``, ``assess_car``,
``assess_fleet``, ``rank_fleet``.
"""

from maintenance.bands import bands_from_nominal, to_indicators
from maintenance.batch import assess_fleet
from maintenance.calibration import METHODS, FleetCalibration, calibrate_fleet, quality_index
from maintenance.economics import discount_factors, economic_effect
from maintenance.estimators import ARForecaster, QualityIndex
from maintenance.fleet import CarAssessment, assess_car, rank_fleet
from maintenance.forecasting import Forecast, forecast
from maintenance.linear_prediction import autocorrelation, levinson_durbin, psi_weights, yule_walker
from maintenance.selection import (
    derivative_norm,
    gaussian_entropy,
    select_by_derivative_norm,
    select_by_entropy,
    select_by_weights,
)
from maintenance.tolerance import (
    ToleranceBand,
    at_least_k_inclusion_exclusion,
    at_least_k_probability,
    independent_intersection_sums,
    intersection_sums,
    tolerance_band,
)
from maintenance.weights import (
    equal_weights,
    fisher_weights,
    inverse_variance_weights,
    lagged_correlations,
    prediction_error_matrix,
    prediction_weights,
    rayleigh_weights,
)

__all__ = [
    "METHODS",
    "ARForecaster",
    "CarAssessment",
    "FleetCalibration",
    "Forecast",
    "QualityIndex",
    "ToleranceBand",
    "assess_car",
    "assess_fleet",
    "at_least_k_inclusion_exclusion",
    "at_least_k_probability",
    "autocorrelation",
    "bands_from_nominal",
    "calibrate_fleet",
    "derivative_norm",
    "discount_factors",
    "economic_effect",
    "equal_weights",
    "fisher_weights",
    "forecast",
    "gaussian_entropy",
    "independent_intersection_sums",
    "intersection_sums",
    "inverse_variance_weights",
    "lagged_correlations",
    "levinson_durbin",
    "prediction_error_matrix",
    "prediction_weights",
    "psi_weights",
    "quality_index",
    "rank_fleet",
    "rayleigh_weights",
    "select_by_derivative_norm",
    "select_by_entropy",
    "select_by_weights",
    "to_indicators",
    "tolerance_band",
    "yule_walker",
]
