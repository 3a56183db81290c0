"""NASA C-MAPSS turbofan run-to-failure records: reading a subset's files, the sensors'
names, the published reference figures, and the scores of a remaining-life estimate.

Each training engine runs to failure; each test engine stops earlier and ``RUL_FDxxx.txt``
holds its true remaining cycles. The engines play the cars: 21 sensors are the parameters,
a cycle is a measurement step.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from maintenance._checks import FloatArray

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


def spearman(a: FloatArray, b: FloatArray) -> float:
    """Spearman rank correlation of ``a`` and ``b`` (shape (n,) each)."""
    ra = np.argsort(np.argsort(a)).astype(np.float64)
    rb = np.argsort(np.argsort(b)).astype(np.float64)
    return float(np.corrcoef(ra, rb)[0, 1])


def phm_score(pred: FloatArray, true: FloatArray) -> float:
    """The PHM08 asymmetric score of predicted vs true remaining cycles (late costs more)."""
    d = pred - true
    return float(np.sum(np.where(d < 0, np.exp(-d / 13.0) - 1.0, np.exp(d / 10.0) - 1.0)))
