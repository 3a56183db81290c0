"""Score the weight methods on a simulated fleet: who is flagged vs. who leaves tolerance."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from maintenance.batch import assess_fleet
from maintenance.calibration import FLAG_RISK, METHODS, calibrate_fleet
from maintenance.simulate import SimulatedFleet


@dataclass(frozen=True)
class MethodScore:
    """Flagging quality of one method on a test fleet.

    Attributes
    ----------
    method : str
    recall : float
        Share of the cars that truly leave tolerance within the horizon that are flagged.
    false_share : float
        Share of flagged cars that do not leave tolerance within the horizon.
    flagged, positives, n_cars : int
    index_band : (float, float)
        Calibrated index band.
    """

    method: str
    recall: float
    false_share: float
    flagged: int
    positives: int
    n_cars: int
    index_band: tuple[float, float]


def compare_methods(
    reference: SimulatedFleet,
    test: SimulatedFleet,
    *,
    methods: Sequence[str] = METHODS,
    order: int = 2,
    window: int = 40,
) -> list[MethodScore]:
    """Calibrate each method on ``reference``'s records and flag ``test``'s cars.

    ``reference`` must be simulated with ``n_times = test's n_times + horizon``
    so that its records show what happened after the cut-off; its histories
    and ``faulty_states`` (trimmed to the histories) are all the calibration
    sees. A test car is flagged when its risk is >= 0.5.
    """
    n_ref = reference.histories.shape[1]
    truth = test.leaves_within_horizon
    out = []
    for method in methods:
        cal = calibrate_fleet(
            reference.histories,
            band=reference.bands,
            faulty=reference.faulty_states[:, :n_ref],
            method=method,
            order=order,
            horizon=test.horizon,
            window=window,
        )
        assessed = assess_fleet(
            test.histories,
            times=test.times,
            band=test.bands,
            weights=cal.weights,
            index_band=cal.index_band,
            order=order,
            horizon=test.horizon,
            window=window,
        )
        risk = np.array([a.risk for a in assessed], dtype=np.float64)
        flagged = risk >= FLAG_RISK
        hits = int(np.sum(flagged & truth))
        out.append(
            MethodScore(
                method=method,
                recall=hits / max(int(truth.sum()), 1),
                false_share=int(np.sum(flagged & ~truth)) / max(int(flagged.sum()), 1),
                flagged=int(flagged.sum()),
                positives=int(truth.sum()),
                n_cars=int(truth.size),
                index_band=cal.index_band,
            )
        )
    return out
