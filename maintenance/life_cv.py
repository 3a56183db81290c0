"""Choosing the life model's options by cross-validation over run-to-failure histories.

Folds are grouped by object (an engine's cycles never sit on both sides).
Each held-out history is cut at random points, as a test object stops some
time before failure; the criterion is the RMSE of the remaining life on
those cuts. The test set of an evaluation is never seen here.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, replace

import numpy as np

from maintenance._checks import FloatArray
from maintenance.life_index import LifeIndex, LifeOptions, best_matches, fit_life_index

# Option values tried; options fixed by the caller are not searched.
DEFAULT_GRID: Mapping[str, tuple[float, ...]] = {
    "cap": (120, 125, 130),
    "curve_degree": (2, 3),
    "match_window": (50, 80, 120),
    "decay": (0.0, 0.02),
    "neighbours": (5, 10, 15),
}
Space = dict[str, tuple[float, ...]]
Key = tuple[tuple[str, float], ...]  # every searched option with its value
_FIT_KEYS = ("cap", "curve_degree", "order", "new_cycles", "worn_cycles", "faulty_cycles", "ridge")
_MATCH_KEYS = ("match_window", "decay")


@dataclass(frozen=True)
class CutProtocol:
    """How held-out histories are cut to imitate test objects.

    Attributes
    ----------
    cuts : int
        Random cut points per held-out history.
    horizon : int
        Largest true remaining life of a cut (the planning horizon, cycles).
    min_cycles : int
        Fewest cycles kept before a cut.
    folds : int
        Cross-validation folds (grouped by history).
    seed : int
    """

    cuts: int = 4
    horizon: int = 150
    min_cycles: int = 30
    folds: int = 5
    seed: int = 0


def cut_histories(
    histories: Sequence[FloatArray], protocol: CutProtocol, rng: np.random.Generator
) -> tuple[list[FloatArray], FloatArray]:
    """Truncate each run-to-failure history at ``protocol.cuts`` random points.

    Returns the truncated histories and their true remaining lives (cycles).
    """
    cut: list[FloatArray] = []
    truth: list[float] = []
    for h in histories:
        top = min(protocol.horizon, h.shape[0] - protocol.min_cycles)
        if top < 1:
            continue
        for r in rng.integers(1, top + 1, size=protocol.cuts):
            cut.append(h[: h.shape[0] - int(r)])
            truth.append(float(r))
    return cut, np.asarray(truth)


def _grid(fixed: Mapping[str, float], grid: Mapping[str, tuple[float, ...]]) -> Space:
    known = {f.name for f in fields(LifeOptions)}
    unknown = set(fixed) - known
    if unknown:
        raise ValueError(f"unknown options {sorted(unknown)}; known: {sorted(known)}")
    return {k: ((fixed[k],) if k in fixed else tuple(v)) for k, v in grid.items()} | {
        k: (v,) for k, v in fixed.items() if k not in grid
    }


def _combos(space: Space, keys: Sequence[str]) -> list[dict[str, float]]:
    names = [k for k in space if k in keys]
    values = itertools.product(*(space[k] for k in names))
    return [dict(zip(names, v, strict=True)) for v in values]


def _typed(base: LifeOptions, values: Mapping[str, float]) -> LifeOptions:
    current = {f.name: getattr(base, f.name) for f in fields(LifeOptions)}
    cast = {k: type(current[k])(v) for k, v in values.items()}
    return replace(base, **cast)


def _fold_errors(
    model: LifeIndex, cut: list[FloatArray], truth: FloatArray, space: Space
) -> dict[Key, FloatArray]:
    """Squared errors per (match options, neighbours) on one fold's cuts."""
    out: dict[Key, FloatArray] = {}
    for match in _combos(space, _MATCH_KEYS):
        m = replace(model, options=_typed(model.options, match))
        found = [best_matches(m, c) for c in cut]
        for k in space.get("neighbours", (model.options.neighbours,)):
            pred = np.array([_nearest_mean(d, r, int(k), m.options.cap) for d, r in found])
            out[(*tuple(match.items()), ("neighbours", float(k)))] = (pred - truth) ** 2
    return out


def _nearest_mean(dist: FloatArray, remaining: FloatArray, k: int, cap: int) -> float:
    usable = np.isfinite(dist)
    if not np.any(usable):
        return float(cap)
    nearest = np.argsort(dist)[: min(k, int(usable.sum()))]
    return float(np.clip(remaining[nearest].mean(), 0.0, cap))


def choose_options(
    histories: Sequence[FloatArray],
    *,
    method: str = "prediction",
    fixed: Mapping[str, float] | None = None,
    grid: Mapping[str, tuple[float, ...]] = DEFAULT_GRID,
    protocol: CutProtocol = CutProtocol(),
) -> tuple[LifeOptions, float]:
    """Options with the lowest grouped-CV RMSE, and that RMSE (cycles).

    ``fixed`` pins options (any :class:`LifeOptions` field); the rest are
    searched over ``grid``.
    """
    space = _grid(fixed or {}, grid)
    rng = np.random.default_rng(protocol.seed)
    order = rng.permutation(len(histories))
    folds = np.array_split(order, min(protocol.folds, len(histories)))
    totals: dict[Key, list[FloatArray]] = {}
    for held in folds:
        train = [histories[i] for i in order if i not in set(held.tolist())]
        cut, truth = cut_histories([histories[i] for i in held], protocol, rng)
        for fit in _combos(space, _FIT_KEYS):
            model = fit_life_index(train, method=method, options=_typed(LifeOptions(), fit))
            for key, err in _fold_errors(model, cut, truth, space).items():
                totals.setdefault((*tuple(fit.items()), *key), []).append(err)
    rmse = {key: float(np.sqrt(np.mean(np.concatenate(e)))) for key, e in totals.items()}
    best = min(rmse, key=lambda key: rmse[key])
    return _typed(LifeOptions(), dict(best)), rmse[best]
