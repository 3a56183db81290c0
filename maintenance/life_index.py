"""Remaining life from a linear quality index matched against run-to-failure histories.

The thesis's index (eq. 4.2) ``y = Wᵀ·x̃`` on the band indicators of
:mod:`maintenance.bands`, carried to a remaining-life estimate:

1. **Parameters**: constant (quantised-flag) sensors are dropped; every other
   sensor is oriented to rise towards failure and normalised so that a new
   object sits at 1 and the mean worn state (last cycles before failure) at 2.
2. **Weights** ``W`` by ``method``: ``prediction`` — the thesis's
   prediction-optimal weights (4.16) with ``Wᵀx0 = 1``; ``fisher`` — the
   discriminant between serviceable (life beyond the cap) and faulty (last
   cycles) states; ``ridge`` — least squares on the life fraction.
3. **Life fraction**: the index is mapped affinely, ``f = scale·y + offset``,
   to the capped piecewise-linear target ``min(RUL, cap)/cap`` (1 = as new,
   0 = failure); two numbers, so ``W`` stays the readable part.
4. **Forecast by similarity** (as RULCLIPPER/Wang 2008): each training
   history's ``f`` is smoothed by a cubic in time; the last ``match_window``
   cycles of the object's ``f`` are slid along every training curve, and the
   remaining life at the best offset of the ``neighbours`` closest curves is
   averaged (capped at ``cap``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from maintenance._checks import FloatArray
from maintenance.weights import fisher_weights, prediction_weights

IndexMethod = Literal["prediction", "fisher", "ridge"]
INDEX_METHODS: tuple[str, ...] = ("prediction", "fisher", "ridge")


@dataclass(frozen=True)
class LifeOptions:
    """Tunables of the life model; :func:`maintenance.life_cv.choose_options` picks them.

    Attributes
    ----------
    cap : int
        Ceiling of the piecewise-linear life target (cycles): earlier than
        ``cap`` cycles before failure an object counts as new.
    match_window : int
        Last cycles of an object's index compared with the training curves.
    neighbours : int
        Closest training curves whose remaining lives are averaged.
    decay : float
        Per-cycle decay of the matching weights (recent cycles count more).
    curve_degree : int
        Degree of the polynomial in time smoothing each training curve.
    order : int
        AR order of the prediction-optimal weights.
    new_cycles, worn_cycles : int
        First/last cycles of a training history that define "new" and "worn".
    faulty_cycles : int
        Last cycles labelled faulty for ``fisher``.
    ridge : float
        Ridge penalty (relative to the number of samples) for ``ridge``.
    """

    cap: int = 125
    match_window: int = 80
    neighbours: int = 10
    decay: float = 0.02
    curve_degree: int = 3
    order: int = 2
    new_cycles: int = 30
    worn_cycles: int = 5
    faulty_cycles: int = 30
    ridge: float = 1e-4


@dataclass(frozen=True)
class LifeIndex:
    """A fitted life model.

    Attributes
    ----------
    keep : ndarray of int, shape (n_kept,)
        0-based columns of the kept sensors.
    sign : ndarray, shape (n_kept,)
        +1 if the sensor rises towards failure, −1 if it falls.
    new, half : ndarray, shape (n_kept,)
        Oriented mean of a new object and the new→worn change (sensor units).
    weights : ndarray, shape (n_kept,)
        ``W`` on the indicators (index change per new→worn change of a sensor).
    scale, offset : float
        Life fraction ``f = scale·Wᵀx̃ + offset``.
    curves : tuple of ndarray
        Smoothed life fraction of each training history, one value per cycle.
    options : LifeOptions
    method : str
    """

    keep: NDArray[np.intp]
    sign: FloatArray
    new: FloatArray
    half: FloatArray
    weights: FloatArray
    scale: float
    offset: float
    curves: tuple[FloatArray, ...]
    options: LifeOptions
    method: str

    def life_fraction(self, sensors: FloatArray) -> FloatArray:
        """Life fraction per cycle of one history, shape (n_cycles, n_sensors) → (n_cycles,)."""
        return np.asarray(self.scale * (self.indicators(sensors) @ self.weights) + self.offset)

    def indicators(self, sensors: FloatArray) -> FloatArray:
        """Band indicators (1 new, 2 worn) of the kept sensors, shape (n_cycles, n_kept)."""
        oriented = sensors[:, self.keep] * self.sign
        return np.asarray(1.0 + (oriented - self.new * self.sign) / self.half)


def varying_sensors(histories: Sequence[FloatArray]) -> NDArray[np.intp]:
    """Columns with more than two distinct values (two values = a quantised flag)."""
    stacked = np.vstack(histories)
    counts = [np.unique(stacked[:, i]).size for i in range(stacked.shape[1])]
    return np.flatnonzero(np.asarray(counts) > 2)


def life_target(length: int, cap: int) -> FloatArray:
    """Capped piecewise-linear life fraction ``min(RUL, cap)/cap`` of a run to failure."""
    remaining = np.arange(length - 1, -1, -1, dtype=np.float64)
    return np.asarray(np.minimum(remaining, cap) / cap)


def _method_weights(
    method: str, ind: list[FloatArray], targets: FloatArray, opts: LifeOptions
) -> FloatArray:
    stacked = np.vstack(ind)
    if method == "prediction":
        return prediction_weights(ind, np.ones(stacked.shape[1]), order=opts.order)
    remaining = np.concatenate([np.arange(i.shape[0] - 1, -1, -1) for i in ind])
    if method == "fisher":
        w = -fisher_weights(stacked[remaining >= opts.cap], stacked[remaining < opts.faulty_cycles])
        return np.asarray(w / np.abs(w).sum())
    if method == "ridge":
        centred = stacked - stacked.mean(axis=0)
        gram = centred.T @ centred + opts.ridge * len(targets) * np.eye(stacked.shape[1])
        w = np.linalg.solve(gram, centred.T @ (targets - targets.mean()))
        return np.asarray(-w / np.abs(w).sum())  # index rises towards failure, like the others
    raise ValueError(f"unknown method {method!r}; choose one of {', '.join(INDEX_METHODS)}")


def _smooth_curve(f: FloatArray, degree: int) -> FloatArray:
    t = np.linspace(0.0, 1.0, f.shape[0])
    return np.asarray(np.polyval(np.polyfit(t, f, degree), t))


def fit_life_index(
    histories: Sequence[FloatArray], *, method: str = "prediction", options: LifeOptions
) -> LifeIndex:
    """Fit the life model on run-to-failure histories (n_cycles, n_sensors); last row = failure."""
    opts = options
    if len(histories) < 3 or min(h.shape[0] for h in histories) <= opts.new_cycles:
        raise ValueError(f"need >= 3 run-to-failure histories longer than {opts.new_cycles} cycles")
    keep = varying_sensors(histories)
    new = np.vstack([h[: opts.new_cycles, keep] for h in histories]).mean(axis=0)
    worn = np.vstack([h[-opts.worn_cycles :, keep] for h in histories]).mean(axis=0)
    sign = np.where(worn >= new, 1.0, -1.0)
    half = np.abs(worn - new)
    half = np.where(half > 0.0, half, 1.0)  # a sensor that does not wear keeps its own unit
    ind = [1.0 + (h[:, keep] * sign - new * sign) / half for h in histories]
    targets = np.concatenate([life_target(h.shape[0], opts.cap) for h in histories])
    w = _method_weights(method, ind, targets, opts)
    y = np.concatenate([i @ w for i in ind])
    scale, offset = np.polyfit(y, targets, 1)
    curves = tuple(_smooth_curve(scale * (i @ w) + offset, opts.curve_degree) for i in ind)
    return LifeIndex(keep, sign, new, half, w, float(scale), float(offset), curves, opts, method)


def _padded_curves(curves: tuple[FloatArray, ...]) -> tuple[FloatArray, NDArray[np.intp]]:
    lives = np.array([c.shape[0] for c in curves], dtype=np.intp)
    table = np.full((len(curves), int(lives.max())), np.nan)
    for j, c in enumerate(curves):
        table[j, : c.shape[0]] = c
    return table, lives


def best_matches(model: LifeIndex, sensors: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Per training curve: the smallest matching distance and the remaining life there.

    Returns two arrays of shape (n_curves,); curves shorter than the matched
    window get distance ``inf``.
    """
    opts = model.options
    z = model.life_fraction(sensors)[-opts.match_window :]
    n = z.shape[0]
    weights = np.exp(-opts.decay * np.arange(n - 1, -1, -1, dtype=np.float64))
    weights /= weights.sum()
    table, lives = _padded_curves(model.curves)
    if table.shape[1] < n:
        return np.full(lives.shape[0], np.inf), np.zeros(lives.shape[0])
    windows = sliding_window_view(table, n, axis=1)  # (n_curves, n_offsets, n)
    dist = ((windows - z) ** 2) @ weights  # NaN where a window runs past a curve's end
    dist = np.where(np.isnan(dist), np.inf, dist)
    offset = np.argmin(dist, axis=1)
    best = dist[np.arange(dist.shape[0]), offset]
    remaining = (lives - (offset + n)).astype(np.float64)
    return np.asarray(best), np.asarray(remaining)


def remaining_life(
    model: LifeIndex, sensors: FloatArray, *, neighbours: int | None = None
) -> float:
    """Remaining cycles of one object from its history (n_cycles, n_sensors), in [0, cap]."""
    k = model.options.neighbours if neighbours is None else neighbours
    dist, remaining = best_matches(model, sensors)
    usable = np.isfinite(dist)
    if not np.any(usable):
        return float(model.options.cap)  # shorter than every matched window: nothing worn yet
    nearest = np.argsort(np.where(usable, dist, np.inf))[: min(k, int(usable.sum()))]
    return float(np.clip(remaining[nearest].mean(), 0.0, model.options.cap))
