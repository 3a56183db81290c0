"""Many cars assessed at once: :func:`maintenance.batch.assess_fleet` per group of cars.

Cars whose history holds every fleet-weighted parameter and has the same number of tests share
one vectorised assessment (the package treats tests as equally spaced steps, so the times only
label the results; each car's own times are put back afterwards). The rest — uncalibrated
fleets, short or ragged histories — go through :func:`maintenance.fleet.assess_car` one by one.
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from maintenance.batch import assess_fleet
from maintenance.fleet import CarAssessment
from maintenance.forecasting import minimum_history
from service.fleet.calibration import FleetIndex
from service.fleet.history import Bands, CarHistory

log = logging.getLogger("depot.fleet")
Outcome = tuple[str, float | None, dict[str, Any]]
# The long arrays (times, index history, forecast) are stored rounded to this many decimals:
# far below any tolerance, and JSON-encoding the shortest repr of a rounded float costs about
# half that of a full-precision one (encoding ~700 floats a car was the job's largest cost).
DECIMALS = 10


@dataclass(frozen=True)
class HistoryLimits:
    """How much of a car's index history a forecast keeps and shows (a car can have millions
    of tests: its whole history in every forecast row made one answer 73 MB and 92 s).

    Attributes
    ----------
    stored : int
        Latest index points kept in a stored forecast (the forecast itself uses every test).
    default : int
        Latest points ``GET /api/v1/cars/{car}/forecast`` returns without ``limit``.
    maximum : int
        Largest ``limit`` accepted (422 above); at most ``stored``.
    chart : int
        Most points the chart draws: the stored history is cut into buckets and each bucket's
        lowest and highest index are drawn, so an excursion is never downsampled away.
    """

    stored: int = 2000
    default: int = 500
    maximum: int = 2000
    chart: int = 600


HISTORY = HistoryLimits()


def _named(names: Sequence[str], values: Any) -> dict[str, float]:
    return dict(zip(names, np.asarray(values, dtype=np.float64).tolist(), strict=True))


def payload_of(result: CarAssessment) -> dict[str, Any]:
    """:meth:`CarAssessment.to_dict` of an ``ok`` assessment, long arrays rounded (DECIMALS),
    the index history cut to its latest ``HISTORY.stored`` points."""
    fc = result.forecast
    series = [result.times[-HISTORY.stored :], result.index[-HISTORY.stored :]]
    if fc is not None:
        series += [result.forecast_times, fc.values, fc.lower, fc.upper]
    rounded = np.round(np.concatenate(series).astype(np.float64), DECIMALS).tolist()
    cuts = list(itertools.accumulate(len(x) for x in series))
    times, index, *ahead = (rounded[a:b] for a, b in zip([0, *cuts[:-1]], cuts, strict=True))
    return {
        "status": result.status,
        "car_id": result.car_id,
        "method": result.method,
        "n_measurements": result.n_measurements,
        "risk": result.risk,
        "first_exit": result.first_exit,
        "k_of_l_probability": result.k_of_l_probability,
        "index_band": list(result.index_band),
        "times": times,
        "index": index,
        "weights": _named(result.names, result.weights),
        "contributions": _named(result.names, result.contributions),
        "parameter_exit_probability": _named(result.names, result.parameter_exit_probability),
        "forecast": None
        if fc is None
        else dict(zip(("times", "values", "lower", "upper"), ahead, strict=True), level=fc.level),
        "reasons": list(result.reasons),
    }


def _groups(histories: Sequence[CarHistory], fleet: FleetIndex, order: int) -> dict[int, list[int]]:
    """Indices of the histories that fit a vectorised assessment, by number of tests."""
    need = max(minimum_history(order, "linear"), order + 3)
    wanted = set(fleet.names)
    groups: dict[int, list[int]] = {}
    for i, history in enumerate(histories):
        if len(history) >= need and wanted <= set(history.names):
            groups.setdefault(len(history), []).append(i)
    return groups


def _matrix(history: CarHistory, names: tuple[str, ...]) -> np.ndarray:
    if history.names == names:
        return history.values
    return history.values[:, [history.names.index(n) for n in names]]


def _retimed(result: CarAssessment, history: CarHistory, horizon: int) -> CarAssessment:
    """The result with the car's own times (days since its first test), as assess_car gives."""
    days = history.days
    dt = float(np.median(np.diff(days))) if days.shape[0] > 1 else 1.0
    ahead = days[-1] + dt * np.arange(1, horizon + 1)
    reasons = result.reasons
    step = result.first_exit
    if step is not None and reasons:
        placeholder = f"(t = {result.forecast_times[step - 1]:g})"
        first = reasons[0].replace(placeholder, f"(t = {ahead[step - 1]:g})", 1)
        reasons = (first, *reasons[1:])
    return replace(result, times=days, forecast_times=ahead, reasons=reasons)


def batch_assessments(
    histories: Sequence[CarHistory],
    bands: Bands,
    fleet: FleetIndex,
    *,
    order: int,
    horizon: int,
    failure_k: int,
) -> dict[int, CarAssessment]:
    """Assessments (by index into ``histories``) of the cars that fit a vectorised run.

    Cars left out — or in a group whose vectorised run fails — are for the per-car path.
    """
    if not fleet.calibrated or not histories:
        return {}
    out: dict[int, CarAssessment] = {}
    band = bands.of(fleet.names)
    for n_tests, members in _groups(histories, fleet, order).items():
        data = np.stack([_matrix(histories[i], fleet.names) for i in members])
        try:
            results = assess_fleet(
                data, times=np.arange(n_tests, dtype=np.float64), band=band,
                weights=fleet.weights, index_band=fleet.index_band, order=order,
                horizon=horizon, k=min(failure_k, len(fleet.names)), names=fleet.names,
                car_ids=[histories[i].car_id for i in members],
            )  # fmt: skip
        except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
            log.info("vectorised forecast of %d cars fell back to per car: %s", len(members), exc)
            continue
        for i, result in zip(members, results, strict=True):
            out[i] = _retimed(result, histories[i], horizon)
    return out
