"""The weighting methods compared on the simulated fleet (issue 6's accuracy table).

Run: .venv/bin/python -m bench.maintenance_methods — weights and index band calibrated on a
reference fleet (seed 1, 800 cars), then a 1,000-car test fleet (seed 3) flagged at risk ≥ 0.5
with a 30-step horizon; recall and the false share of flagged cars per method. Then, if
the NASA C-MAPSS FD001 files are present (../shared/data/real/cmapss_fd001), the remaining-life
figures of ``maintenance.cmapss.evaluate`` per index method, the pseudo-split of the training
engines, and the index weights per sensor.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from maintenance import METHODS
from maintenance.cmapss import evaluate, pseudo_split
from maintenance.evaluation import compare_methods
from maintenance.life_index import INDEX_METHODS
from maintenance.simulate import simulate_fleet

FD001 = next(
    (
        p / "shared" / "data" / "real" / "cmapss_fd001"
        for p in Path(__file__).resolve().parents
        if (p / "shared" / "data" / "real").is_dir()
    ),
    Path("cmapss_fd001"),
)


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


def fd001_table() -> None:
    if not (FD001 / "train_FD001.txt").exists():
        print(f"\n(C-MAPSS FD001 not found at {FD001}: remaining-life table skipped)")
        return
    print("\n## remaining life on C-MAPSS FD001 (options by grouped CV on the train file)")
    print(f"{'method':11s} {'RMSE':>6s} {'score':>7s} {'CV':>6s} {'pseudo':>7s}  options")
    shown = None
    for method in INDEX_METHODS:
        r = evaluate(
            FD001 / "train_FD001.txt",
            FD001 / "test_FD001.txt",
            FD001 / "RUL_FD001.txt",
            method=method,
        )
        p = pseudo_split(FD001 / "train_FD001.txt", method=method)
        o = r.options
        print(
            f"{method:11s} {r.rmse:6.2f} {r.score:7.1f} {r.cv_rmse:6.2f} {p.rmse:7.2f}  "
            f"cap {o.cap}, window {o.match_window}, k {o.neighbours}, decay {o.decay}, "
            f"degree {o.curve_degree}"
        )
        shown = shown or r
    assert shown is not None
    print(f"\nindex weights ({shown.method}; index change per new→worn change of the sensor)")
    print(f"{'sensor':>6s} {'name':40s} {'weight':>7s} {'towards failure':>16s}")
    for w in shown.weights:
        print(f"{w.sensor:6d} {w.name:40s} {w.weight:7.3f} {w.direction:>6s} {w.worn_change:+9.4g}")
    print(f"life fraction = {shown.scale:.3f}·index + {shown.offset:.3f}")


if __name__ == "__main__":
    started = time.perf_counter()
    np.seterr(all="ignore")
    methods_table()
    fd001_table()
    print(f"\ntotal {time.perf_counter() - started:.1f} s")
