"""Honest check on real data: NASA C-MAPSS turbofan run-to-failure records.

:func:`evaluate` is the general API (any C-MAPSS subset's files, options chosen
by grouped cross-validation on the training engines, model of
:mod:`maintenance.life_index`). :func:`evaluate_fd001` below is the earlier
AR-trend forecast of the index to its threshold, kept as the reference
(RMSE 24.1 on FD001).

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

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from maintenance._checks import FloatArray
from maintenance.bands import to_indicators
from maintenance.calibration import method_weights, quality_index
from maintenance.forecasting import Trend, forecast
from maintenance.life_cv import CutProtocol, choose_options, cut_histories
from maintenance.life_index import LifeIndex, LifeOptions, fit_life_index, remaining_life
from maintenance.selection import gaussian_entropy
from maintenance.weights import prediction_weights

N_SENSORS = 21
PUBLISHED_RMSE: dict[str, float] = {
    "deep LSTM (Zheng et al. 2017)": 16.14,
    "single-layer LSTM (arXiv 2604.27234)": 14.93,
    "1D-CNN (arXiv 2604.27234)": 16.97,
}


@dataclass(frozen=True)
class Engines:
    """Sensor histories of a C-MAPSS split: one (n_cycles, 21) array per engine."""

    units: tuple[int, ...]
    sensors: tuple[FloatArray, ...]


def load_split(path: Path | str) -> Engines:
    """Read ``train_FD001.txt`` / ``test_FD001.txt`` (unit, cycle, 3 settings, 21 sensors)."""
    table = np.loadtxt(Path(path))
    if table.ndim != 2 or table.shape[1] < 5 + N_SENSORS:
        raise ValueError(f"{path}: expected 26 columns, got shape {table.shape}")
    units = tuple(int(u) for u in np.unique(table[:, 0]))
    sensors = []
    for u in units:
        rows = table[table[:, 0] == u]
        rows = rows[np.argsort(rows[:, 1])]
        sensors.append(np.asarray(rows[:, 5 : 5 + N_SENSORS], dtype=np.float64))
    return Engines(units, tuple(sensors))


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


def _spearman(a: FloatArray, b: FloatArray) -> float:
    ra = np.argsort(np.argsort(a)).astype(np.float64)
    rb = np.argsort(np.argsort(b)).astype(np.float64)
    return float(np.corrcoef(ra, rb)[0, 1])


def _phm_score(pred: FloatArray, true: FloatArray) -> float:
    d = pred - true
    return float(np.sum(np.where(d < 0, np.exp(-d / 13.0) - 1.0, np.exp(d / 10.0) - 1.0)))


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
        score=_phm_score(pred, true),
        baseline_rmse=float(np.sqrt(np.mean((np.minimum(baseline, max_rul) - true) ** 2))),
        rank_correlation=_spearman(pred, true),
    )


# Sensor names of C-MAPSS (Saxena et al. 2008, table 2), 1-based sensor numbers.
SENSOR_NAMES: tuple[str, ...] = (
    "T2 fan inlet temperature",
    "T24 LPC outlet temperature",
    "T30 HPC outlet temperature",
    "T50 LPT outlet temperature",
    "P2 fan inlet pressure",
    "P15 bypass-duct pressure",
    "P30 HPC outlet pressure",
    "Nf physical fan speed",
    "Nc physical core speed",
    "epr engine pressure ratio",
    "Ps30 HPC outlet static pressure",
    "phi fuel flow / Ps30",
    "NRf corrected fan speed",
    "NRc corrected core speed",
    "BPR bypass ratio",
    "farB burner fuel-air ratio",
    "htBleed bleed enthalpy",
    "Nf_dmd demanded fan speed",
    "PCNfR_dmd demanded corrected fan speed",
    "W31 HPT coolant bleed",
    "W32 LPT coolant bleed",
)


@dataclass(frozen=True)
class SensorWeight:
    """One sensor's part in the index.

    Attributes
    ----------
    sensor : int
        1-based C-MAPSS sensor number.
    name : str
    weight : float
        Index change when this sensor moves from its new to its worn mean.
    direction : str
        ``"rises"`` or ``"falls"`` towards failure.
    worn_change : float
        Mean new→worn change in the sensor's own unit (signed).
    """

    sensor: int
    name: str
    weight: float
    direction: str
    worn_change: float


@dataclass(frozen=True)
class Evaluation:
    """Remaining-life figures of :func:`evaluate` on one subset's test engines.

    Attributes
    ----------
    method : str
    options : LifeOptions
        Chosen by grouped CV on the training engines (or fixed by the caller).
    cv_rmse : float
        Cross-validated RMSE of those options on cut training engines (cycles).
    weights : tuple of SensorWeight
        Index weights per kept sensor (constant sensors are dropped).
    scale, offset : float
        Life fraction ``f = scale·index + offset``.
    predicted_rul, true_rul : ndarray, shape (n_test_engines,)
        In the test file's engine order (cycles).
    rmse, score : float
        RUL RMSE (cycles) and the PHM08 asymmetric score (late costs more).
    baseline_rmse : float
        No-skill reference: mean training life minus the cycles seen, capped.
    """

    method: str
    options: LifeOptions
    cv_rmse: float
    weights: tuple[SensorWeight, ...]
    scale: float
    offset: float
    predicted_rul: FloatArray
    true_rul: FloatArray
    rmse: float
    score: float
    baseline_rmse: float


def _sensor_weights(model: LifeIndex) -> tuple[SensorWeight, ...]:
    return tuple(
        SensorWeight(
            sensor=int(c) + 1,
            name=SENSOR_NAMES[int(c)] if int(c) < len(SENSOR_NAMES) else f"sensor {int(c) + 1}",
            weight=float(w),
            direction="rises" if s > 0 else "falls",
            worn_change=float(s * h),
        )
        for c, w, s, h in zip(model.keep, model.weights, model.sign, model.half, strict=True)
    )


def fit_and_predict(
    train: Sequence[FloatArray],
    test: Sequence[FloatArray],
    true: FloatArray,
    *,
    method: str,
    protocol: CutProtocol,
    options: Mapping[str, float],
) -> Evaluation:
    """Choose options by CV on ``train``, fit on all of it, predict ``test`` (histories)."""
    chosen, cv_rmse = choose_options(train, method=method, fixed=options, protocol=protocol)
    model = fit_life_index(train, method=method, options=chosen)
    pred = np.array([remaining_life(model, s) for s in test])
    lives = np.array([s.shape[0] for s in train], dtype=np.float64)
    seen = np.array([s.shape[0] for s in test])
    baseline = np.array([np.mean(np.clip(lives - n, 0, None)) for n in seen])
    return Evaluation(
        method=method,
        options=chosen,
        cv_rmse=cv_rmse,
        weights=_sensor_weights(model),
        scale=model.scale,
        offset=model.offset,
        predicted_rul=pred,
        true_rul=true,
        rmse=float(np.sqrt(np.mean((pred - true) ** 2))),
        score=_phm_score(pred, true),
        baseline_rmse=float(np.sqrt(np.mean((np.minimum(baseline, chosen.cap) - true) ** 2))),
    )


def evaluate(
    train_path: Path | str,
    test_path: Path | str,
    rul_path: Path | str,
    *,
    method: str = "prediction",
    protocol: CutProtocol = CutProtocol(),
    **options: float,
) -> Evaluation:
    """Remaining life of a C-MAPSS subset's test engines, fitted on its train file only.

    Parameters
    ----------
    train_path, test_path, rul_path : path
        ``train_FDxxx.txt``, ``test_FDxxx.txt``, ``RUL_FDxxx.txt`` (same format
        for every subset: unit, cycle, 3 settings, 21 sensors; one RUL per test
        engine in the test file's order).
    method : {"prediction", "fisher", "ridge"}
        Index weights (see :mod:`maintenance.life_index`).
    protocol : CutProtocol
        Cross-validation protocol on the training engines.
    **options
        Any :class:`maintenance.life_index.LifeOptions` field to fix; the
        others are chosen by grouped CV on the training engines.
    """
    train = load_split(train_path)
    test = load_split(test_path)
    true = np.loadtxt(Path(rul_path)).reshape(-1)
    if true.shape[0] != len(test.sensors):
        raise ValueError(
            f"{rul_path} lists {true.shape[0]} values but {test_path} has "
            f"{len(test.sensors)} engines: give one RUL per test engine"
        )
    return fit_and_predict(
        train.sensors, test.sensors, true, method=method, protocol=protocol, options=options
    )


def pseudo_split(
    train_path: Path | str,
    *,
    method: str = "prediction",
    test_share: float = 0.3,
    seed: int = 1,
    protocol: CutProtocol = CutProtocol(),
    **options: float,
) -> Evaluation:
    """Generality check without the test file: hold out ``test_share`` of the training engines.

    The held-out engines are cut at ``protocol.cuts`` random points each (true remaining
    life uniform in 1…``protocol.horizon``); options are chosen by CV on the
    rest only.
    """
    train = load_split(train_path)
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(train.sensors))
    n_test = max(1, round(test_share * len(order)))
    held = [train.sensors[i] for i in order[:n_test]]
    rest = [train.sensors[i] for i in order[n_test:]]
    cut, truth = cut_histories(held, protocol, rng)
    return fit_and_predict(rest, cut, truth, method=method, protocol=protocol, options=options)
