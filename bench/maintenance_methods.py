"""The weighting methods compared on the simulated fleet (issue 6's accuracy table).

Run: .venv/bin/python -m bench.maintenance_methods — weights and index band calibrated on a
reference fleet (seed 1, 800 cars), then a 1,000-car test fleet (seed 3) flagged at risk ≥ 0.5
with a 30-step horizon; recall and the false share of flagged cars per method.
"""

from __future__ import annotations

import time

import numpy as np

from maintenance import METHODS
from maintenance.evaluation import compare_methods
from maintenance.simulate import simulate_fleet


def methods_table() -> None:
    reference = simulate_fleet(800, n_times=230, seed=1)
    test = simulate_fleet(1000, seed=3)
    print(
        "\n## methods on the simulated fleet (reference seed 1: 800 cars; test seed 3: 1000 cars)"
    )
    print(
        f"{'method':18s} {'recall':>7s} {'false':>7s} {'flagged':>8s} {'leaving':>8s}  index band"
    )
    for s in compare_methods(reference, test, methods=METHODS):
        lo, hi = s.index_band
        print(
            f"{s.method:18s} {s.recall:7.3f} {s.false_share:7.3f} {s.flagged:8d} "
            f"{s.positives:8d}  [{lo:.3f}, {hi:.3f}]"
        )


if __name__ == "__main__":
    started = time.perf_counter()
    np.seterr(all="ignore")
    methods_table()
    print(f"\ntotal {time.perf_counter() - started:.1f} s")
