"""Honest check on real data: remaining life of NASA C-MAPSS turbofan engines.

:func:`evaluate` is the general API: any C-MAPSS subset's files, every option chosen by
grouped cross-validation on the training engines (never the test set), the model of
:mod:`maintenance.life_index` (a linear index fitted to the life fraction, its weights
reported per sensor). The files and scores are in :mod:`maintenance.cmapss_data`; the
earlier AR-trend forecast, kept as the reference, in :mod:`maintenance.cmapss_reference`
(both re-exported here).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from maintenance._checks import FloatArray
from maintenance.cmapss_data import (
    N_SENSORS,
    PUBLISHED_RMSE,
    SENSOR_NAMES,
    Engines,
    load_split,
    phm_score,
    spearman,
)
from maintenance.cmapss_reference import CmapssResult, evaluate_fd001
from maintenance.life_cv import CutProtocol, choose_options, cut_histories
from maintenance.life_index import LifeIndex, LifeOptions, fit_life_index, remaining_life

__all__ = [
    "N_SENSORS",
    "PUBLISHED_RMSE",
    "SENSOR_NAMES",
    "CmapssResult",
    "Engines",
    "Evaluation",
    "SensorWeight",
    "evaluate",
    "evaluate_fd001",
    "fit_and_predict",
    "load_split",
    "phm_score",
    "pseudo_split",
    "spearman",
]


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
        score=phm_score(pred, true),
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
