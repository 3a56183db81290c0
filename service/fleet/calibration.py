"""Fleet calibration of the index: weights and index band from the depot's own records.

Uncalibrated, the index band is ``(0, 2)`` — the weighted deviation must reach a whole
tolerance half-width — which a car whose few stable parameters drift to their limits never
reaches: the risk would read 0 % until the car has failed. The thesis sets the index band for a
chosen false-alarm probability on serviceable states; the service takes those states from the
stored history itself: a test is *faulty* when at least K parameters were measured outside
their tolerance (the spec's K-of-L failure criterion), serviceable otherwise.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from maintenance.bands import INDICATOR_BAND, to_indicators
from maintenance.calibration import calibrate_fleet
from service.fleet.history import Bands, CarHistory


@dataclass(frozen=True)
class CalibrationRules:
    """When the fleet's weights and index band are calibrated (README "Maintenance forecasts").

    Attributes
    ----------
    sample_cars : int
        The calibration sample: the first this many cars (in the stream's order) with
        ``sample_tests`` tests — enough for the band's tails, one quick pass over the start of
        the measurement stream.
    sample_tests : int
        A car takes part with its latest this many tests, and only when it has that many.
    min_cars : int
        Fewer cars with ``sample_tests`` tests leave the fleet uncalibrated: the index band is
        the indicator band :data:`maintenance.bands.INDICATOR_BAND` ``(0, 2)`` (the weighted
        deviation must reach a whole tolerance half-width) and the weights are fitted per car.
    """

    sample_cars: int = 400
    sample_tests: int = 60
    min_cars: int = 3


CALIBRATION = CalibrationRules()
SAMPLE_CARS = CALIBRATION.sample_cars  # the job's first read (kept for bench/)


@dataclass(frozen=True)
class FleetIndex:
    """Fleet weights over ``names`` and the index band; ``note`` says how they were set."""

    names: tuple[str, ...]
    weights: np.ndarray | None
    index_band: tuple[float, float]
    note: str

    @property
    def calibrated(self) -> bool:
        return self.weights is not None


def faulty_tests(history: CarHistory, bands: Bands, failure_k: int) -> np.ndarray:
    """Per test: at least ``failure_k`` parameters outside their tolerance band."""
    ind = to_indicators(history.values, bands.of(history.names))
    lo, hi = INDICATOR_BAND
    return np.asarray(np.sum((ind < lo) | (ind > hi), axis=1) >= failure_k)


def calibrate(
    stream: Iterable[CarHistory],
    bands: Bands,
    *,
    method: str,
    order: int,
    failure_k: int,
    false_alarm: float,
) -> FleetIndex:
    """Fleet weights and index band from a sample of ``stream``, or why there are none."""
    sample = [h for h in _sample(stream)]
    rules = CALIBRATION
    if len(sample) < rules.min_cars:
        why = f"only {len(sample)} cars have {rules.sample_tests} tests or more"
        return FleetIndex((), None, INDICATOR_BAND, _uncalibrated(f"{why} (need {rules.min_cars})"))
    common = set(sample[0].names).intersection(*(h.names for h in sample[1:]))
    names = tuple(n for n in sample[0].names if n in common)
    if not names:
        return FleetIndex(
            (), None, INDICATOR_BAND, _uncalibrated("no parameter is measured on every car")
        )
    cols = [[h.names.index(n) for n in names] for h in sample]
    last = rules.sample_tests
    data = np.stack([h.values[-last:][:, c] for h, c in zip(sample, cols, strict=True)])
    ind = to_indicators(data, bands.of(names))  # every sampled car at once
    lo_i, hi_i = INDICATOR_BAND
    labels = np.sum((ind < lo_i) | (ind > hi_i), axis=2) >= failure_k  # as faulty_tests
    try:
        cal = calibrate_fleet(
            data, band=bands.of(names), faulty=labels, method=method, order=order,
            false_alarm=false_alarm,
        )  # fmt: skip
    except (ValueError, np.linalg.LinAlgError) as exc:
        return FleetIndex((), None, INDICATOR_BAND, _uncalibrated(str(exc)))
    lo, hi = cal.index_band
    note = (
        f"fleet {method} weights and index band [{lo:.3f}, {hi:.3f}] from {len(sample)} cars' "
        f"last {last} tests ({int(labels.sum())} faulty), false alarm {false_alarm:g}"
    )
    return FleetIndex(names, cal.weights, (lo, hi), note)


def _sample(stream: Iterable[CarHistory]) -> Iterable[CarHistory]:
    taken = 0
    for history in stream:
        if len(history) >= CALIBRATION.sample_tests and history.names:
            yield history
            taken += 1
            if taken >= CALIBRATION.sample_cars:
                return


def _uncalibrated(why: str) -> str:
    lo, hi = INDICATOR_BAND
    return f"uncalibrated index band ({lo:g}, {hi:g}) and per-car weights: {why}"
