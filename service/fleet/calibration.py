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

# The calibration sample: the last tests of up to this many cars (enough for the band's tails,
# small enough to stay one quick pass over the start of the measurement stream).
SAMPLE_CARS = 400
SAMPLE_TESTS = 60
MIN_CARS = 3


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
    return np.asarray(np.sum((ind < 0.0) | (ind > 2.0), axis=1) >= failure_k)


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
    if len(sample) < MIN_CARS:
        return FleetIndex((), None, INDICATOR_BAND, _uncalibrated(f"only {len(sample)} cars have "
                          f"{SAMPLE_TESTS} tests or more (need {MIN_CARS})"))  # fmt: skip
    common = set(sample[0].names).intersection(*(h.names for h in sample[1:]))
    names = tuple(n for n in sample[0].names if n in common)
    if not names:
        return FleetIndex(
            (), None, INDICATOR_BAND, _uncalibrated("no parameter is measured on every car")
        )
    cols = [[h.names.index(n) for n in names] for h in sample]
    data = np.stack([h.values[-SAMPLE_TESTS:][:, c] for h, c in zip(sample, cols, strict=True)])
    ind = to_indicators(data, bands.of(names))  # every sampled car at once
    labels = np.sum((ind < 0.0) | (ind > 2.0), axis=2) >= failure_k  # as faulty_tests
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
        f"last {SAMPLE_TESTS} tests ({int(labels.sum())} faulty), false alarm {false_alarm:g}"
    )
    return FleetIndex(names, cal.weights, (lo, hi), note)


def _sample(stream: Iterable[CarHistory]) -> Iterable[CarHistory]:
    taken = 0
    for history in stream:
        if len(history.taken_at) >= SAMPLE_TESTS and history.names:
            yield history
            taken += 1
            if taken >= SAMPLE_CARS:
                return


def _uncalibrated(why: str) -> str:
    return f"uncalibrated index band (0, 2) and per-car weights: {why}"
