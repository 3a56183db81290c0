"""The earlier C-MAPSS FD001 check, kept as the reference: an AR-trend forecast of the
quality index to its failure threshold (RMSE 24.1 on FD001). The general API is
:func:`maintenance.cmapss.evaluate`.

Each training engine runs to failure; each test engine stops earlier and
``RUL_FD001.txt`` holds its true remaining cycles. The engines play the cars:
21 sensors are the parameters, a cycle is a measurement step.

Pipeline (all fitted on the training engines only):

1. Predictive parameters: drop sensors that never vary (entropy ``-inf`` or
   negligible spread); keep those whose derivative norm of the life-normalised
   trend is visible (|correlation with life fraction| >= 0.5).
2. Bands: each sensor is oriented so that it rises towards failure; centre =
   mean of the first 30 cycles (new engine), half-width = mean over the last
   5 cycles − centre (failure sits at the upper tolerance limit).
3. Weights of the quality index by the chosen method; faulty states = the last
   ``faulty_cycles`` of each training engine.
4. Failure threshold of the index = median of the index over the last 5 cycles
   of the training engines.
5. Test engine: forecast the index (AR + trend over the last ``window``
   cycles) until it crosses the threshold; the step of the first crossing is
   the predicted remaining life (capped at ``max_rul``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from maintenance._checks import FloatArray
from maintenance.bands import to_indicators
from maintenance.calibration import method_weights, quality_index
from maintenance.cmapss_data import N_SENSORS, Engines, load_split, phm_score, spearman
from maintenance.forecasting import Trend, forecast
from maintenance.selection import gaussian_entropy
from maintenance.weights import prediction_weights


@dataclass(frozen=True)
class CmapssResult:
    """RUL figures on the FD001 test engines.

    Attributes
    ----------
    method : str
    sensors : tuple of int
        1-based sensor numbers kept as predictive parameters.
    predicted_rul, true_rul : ndarray, shape (n_engines,)
    rmse : float
        RUL root-mean-square error (cycles).
    score : float
        PHM08 asymmetric score (late predictions cost more).
    baseline_rmse : float
        RMSE of predicting the mean training-engine remaining life at the same
        cut-off lengths (a no-skill reference).
    rank_correlation : float
        Spearman correlation of predicted and true RUL (ranking the fleet).
    """

    method: str
    sensors: tuple[int, ...]
    predicted_rul: FloatArray
    true_rul: FloatArray
    rmse: float
    score: float
    baseline_rmse: float
    rank_correlation: float


def _select_sensors(train: Engines) -> NDArray[np.intp]:
    stacked = np.vstack(train.sensors)
    spread = np.isfinite(gaussian_entropy(stacked)) & (stacked.std(axis=0) > 1e-6)
    life = np.concatenate([np.linspace(0.0, 1.0, s.shape[0]) for s in train.sensors])
    corr = np.array(
        [
            abs(np.corrcoef(stacked[:, i], life)[0, 1]) if spread[i] else 0.0
            for i in range(N_SENSORS)
        ]
    )
    return np.flatnonzero(corr >= 0.5)


def _orientation(train: Engines, keep: NDArray[np.intp]) -> FloatArray:
    """+1 for sensors that rise towards failure, −1 for those that fall."""
    new = np.vstack([s[:30, keep] for s in train.sensors]).mean(axis=0)
    worn = np.vstack([s[-5:, keep] for s in train.sensors]).mean(axis=0)
    return np.asarray(np.where(worn >= new, 1.0, -1.0))


def _bands(train: Engines, keep: NDArray[np.intp], sign: FloatArray) -> FloatArray:
    new = np.vstack([s[:30, keep] * sign for s in train.sensors]).mean(axis=0)
    worn = np.vstack([s[-5:, keep] * sign for s in train.sensors]).mean(axis=0)
    half = np.abs(worn - new)
    return np.column_stack([new - half, new + half])


def evaluate_fd001(
    directory: Path | str,
    *,
    method: str = "prediction",
    order: int = 2,
    window: int = 80,
    trend: Trend = "quadratic",
    faulty_cycles: int = 30,
    max_rul: int = 125,
) -> CmapssResult:
    """Predict the remaining cycles of the FD001 test engines from the quality index.

    Parameters
    ----------
    directory : path
        Folder with ``train_FD001.txt``, ``test_FD001.txt``, ``RUL_FD001.txt``.
    method : str
        Weights method (see :func:`maintenance.calibration.method_weights`).
    order : int
        AR order of the index forecast.
    window : int
        Cycles used for the trend/AR fit of each test engine.
    trend : {"linear", "quadratic", "none"}
        Index trend model (degradation accelerates, so ``quadratic`` by default).
    faulty_cycles : int
        Last cycles of each training engine labelled faulty (for ``fisher``).
    max_rul : int
        Predictions are capped here (the usual piecewise-linear RUL ceiling).
    """
    folder = Path(directory)
    train = load_split(folder / "train_FD001.txt")
    test = load_split(folder / "test_FD001.txt")
    true = np.loadtxt(folder / "RUL_FD001.txt").reshape(-1)
    if true.shape[0] != len(test.sensors):
        raise ValueError("RUL_FD001.txt must list one value per test engine")
    keep = _select_sensors(train)
    sign = _orientation(train, keep)  # so every sensor wears towards its upper limit
    bands = _bands(train, keep, sign)
    ind_train = [to_indicators(s[:, keep] * sign, bands) for s in train.sensors]
    faulty = np.concatenate(
        [np.arange(s.shape[0]) >= s.shape[0] - faulty_cycles for s in ind_train]
    )
    if method == "prediction":
        w = prediction_weights(ind_train, np.ones(keep.size), order=order)
    else:
        w = method_weights(method, np.vstack(ind_train), order=order, faulty=faulty)
    idx_train = [quality_index(i, w) for i in ind_train]
    threshold = float(np.median([y[-5:].mean() for y in idx_train]))
    start = float(np.median([y[:30].mean() for y in idx_train]))
    band = (-1e9, threshold) if threshold > start else (threshold, 1e9)
    pred = np.empty(true.shape[0])
    for e, s in enumerate(test.sensors):
        y = quality_index(to_indicators(s[:, keep] * sign, bands), w)
        fc = forecast(y, order=order, horizon=max_rul, band=band, trend=trend, window=window)
        pred[e] = float(fc.first_exit) if fc.first_exit is not None else float(max_rul)
    lengths = np.array([s.shape[0] for s in test.sensors])
    lives = np.array([s.shape[0] for s in train.sensors], dtype=np.float64)
    baseline = np.array([np.mean(np.clip(lives - n, 0, None)) for n in lengths])
    return CmapssResult(
        method=method,
        sensors=tuple(int(i) + 1 for i in keep),
        predicted_rul=pred,
        true_rul=true,
        rmse=float(np.sqrt(np.mean((pred - true) ** 2))),
        score=phm_score(pred, true),
        baseline_rmse=float(np.sqrt(np.mean((np.minimum(baseline, max_rul) - true) ** 2))),
        rank_correlation=spearman(pred, true),
    )
