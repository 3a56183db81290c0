"""Benchmark of the maintenance package: speed, method comparison, real-data check.

Run: .venv/bin/python -m bench.maintenance_forecast

1. Computation throughput (20 parameters × 200 measurements per car, 30-step
   horizon): ``assess_car`` with fleet weights, with per-car prediction
   weights, and the vectorized ``assess_fleet``. (The end-to-end PostgreSQL
   job of issue 6 — reading histories and writing forecasts — belongs to the
   service; these are the computation-only figures.)
2. NASA C-MAPSS FD001: RUL RMSE of the index forecast beside published peers.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from maintenance import METHODS, assess_fleet, calibrate_fleet
from maintenance.cmapss import PUBLISHED_RMSE, evaluate_fd001
from maintenance.fleet import assess_car, rank_fleet
from maintenance.simulate import simulate_fleet

ROOT = Path(__file__).resolve().parents[1]
CMAPSS = ROOT.parent / "shared" / "data" / "real" / "cmapss_fd001"


def throughput() -> None:
    fleet = simulate_fleet(1000, seed=11)
    ref = simulate_fleet(300, n_times=230, seed=12)
    cal = calibrate_fleet(ref.histories, band=ref.bands, faulty=ref.faulty_states[:, :230])
    print("## assess_car throughput (20 params x 200 measurements, horizon 30, one process)")
    print("   (CPU-time rate is robust to other load on the machine; wall rate as measured)")
    for label, kwargs in (
        ("fleet weights + calibrated band", {"weights": cal.weights, "index_band": cal.index_band}),
        ("per-car prediction weights", {"weights_method": "prediction"}),
    ):
        n = 1000 if "fleet" in label else 300
        t0, c0 = time.perf_counter(), time.process_time()
        out = [
            assess_car(h, times=fleet.times, band=fleet.bands, window=40, **kwargs)
            for h in fleet.histories[:n]
        ]
        dt, cpu = time.perf_counter() - t0, time.process_time() - c0
        rank_fleet(out)
        _report(label, n, dt, cpu)
    t0, c0 = time.perf_counter(), time.process_time()
    batch = assess_fleet(fleet.histories, times=fleet.times, band=fleet.bands, weights=cal.weights,
                         index_band=cal.index_band, names=fleet.names)  # fmt: skip
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    rank_fleet(batch)
    _report("assess_fleet (vectorized, same results)", len(batch), dt, cpu)


def _report(label: str, n: int, wall: float, cpu: float) -> None:
    print(
        f"{label:40s} {n / cpu:8.0f} cars/s CPU ({1e3 * cpu / n:.3f} ms/car), "
        f"{n / wall:8.0f} cars/s wall"
    )


def cmapss_table() -> None:
    print("\n## NASA C-MAPSS FD001 test engines (100), RUL from the index forecast")
    if not (CMAPSS / "train_FD001.txt").exists():
        print(f"skipped: data not found at {CMAPSS}")
        return
    print(f"{'method':18s} {'RMSE':>7s} {'PHM score':>10s} {'Spearman':>9s} {'no-skill RMSE':>14s}")
    for method in METHODS:
        r = evaluate_fd001(CMAPSS, method=method)
        print(
            f"{method:18s} {r.rmse:7.2f} {r.score:10.0f} {r.rank_correlation:9.3f} "
            f"{r.baseline_rmse:14.2f}"
        )
    for name, rmse in PUBLISHED_RMSE.items():
        print(f"published: {name:40s} RMSE {rmse:.2f}")
    print(f"sensors kept: {evaluate_fd001(CMAPSS).sensors}")


def main() -> int:
    t0 = time.perf_counter()
    np.seterr(all="ignore")
    throughput()
    cmapss_table()
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
