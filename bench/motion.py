"""Benchmark of the motion package (prints its figures; not a test).

* TrackFilter updates per second on one core (target ≥ 50,000/s), for the
  realistic mix (10 Hz accelerometer, 1 Hz GNSS speed 2 s late, markers),
  for accelerometer-only samples, and for the worst case of a delayed GNSS
  speed in every sample;
* measure_smear / speed_from_image time per 1080p image;
* the fusion accuracy on generated runs against both baselines.

Run: ``python -m bench.motion [--runs N]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

from motion import optical
from motion import simulation as sim
from motion.fusion import FilterConfig, TrackFilter


def _updates_per_s(run: sim.Run, mode: str, repeat: int = 3) -> float:
    t = [float(x) for x in run.t]
    a = [float(x) for x in run.accel_meas]
    n = len(t)
    if mode == "mix":
        gs = [run.gnss_speed.get(k) for k in range(n)]
    elif mode == "accel":
        gs = [None] * n
    else:  # every sample carries a delayed GNSS speed
        gs = [float(abs(run.v_true[max(0, k - 20)])) for k in range(n)]
    marker_at = {}
    for tp, mid, _ in run.marker_pass:
        k = min(range(n), key=lambda i: abs(t[i] - tp))
        marker_at[k] = mid
    best = 0.0
    for _ in range(repeat):
        f = TrackFilter(
            run.table, FilterConfig(initial_position_m=run.start_estimate_m, gnss_delay_s=2.0)
        )
        step = f.step
        t0 = time.perf_counter()
        for k in range(n):
            step(t[k], a[k], gs[k], None, marker_at.get(k) if mode == "mix" else None)
        dt = time.perf_counter() - t0
        best = max(best, n / dt)
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=100, help="generated runs for the accuracy figures")
    ap.add_argument("--images", type=int, default=5)
    args = ap.parse_args(argv)

    run = sim.generate_run(0)
    print(f"TrackFilter, one core, {run.t.size} samples per pass (best of 3):")
    for mode, label in [
        ("mix", "10 Hz accel + 1 Hz GNSS (2 s late) + markers"),
        ("accel", "accelerometer only"),
        ("every", "delayed GNSS speed in every sample (worst case)"),
    ]:
        print(f"  {label:50s} {_updates_per_s(run, mode):10,.0f} updates/s")
    f = TrackFilter(run.table, FilterConfig(initial_position_m=0.0, gnss_delay_s=2.0))
    for k in range(600):
        f.step(float(run.t[k]), float(run.accel_meas[k]), run.gnss_speed.get(k))
    snap = json.dumps(f.to_dict())
    print(f"  snapshot of one filter: {len(snap):,} bytes of JSON")

    times = []
    errs = []
    for i in range(args.images):
        kmh = 20 + 60 * i / max(1, args.images - 1)
        img = optical.render_stripes(kmh / 3.6, seed=i)
        t0 = time.perf_counter()
        r = optical.speed_from_image(img, distance_m=1.0, pixel_fov_rad=0.94e-3, row_time_s=1e-4)
        times.append(time.perf_counter() - t0)
        errs.append(abs(r.speed_kmh - kmh) / kmh * 100)
    print(
        f"measure_smear + speed on 1920×1080: "
        f"median {statistics.median(times) * 1000:.0f} ms per image "
        f"(max {max(times) * 1000:.0f} ms), speed error ≤ {max(errs):.3f} % over 20–80 km/h"
    )

    t0 = time.perf_counter()
    rep = sim.evaluate(range(args.runs))
    dt = time.perf_counter() - t0
    print(f"final-stop position error over {rep.runs} generated runs ({dt:.0f} s):")
    for name, st in rep.summary().items():
        print(
            f"  {name:15s} ≤5 m in {st['within_threshold'] * 100:5.1f} %  "
            f"median {st['median_m']:9.2f} m  "
            f"p95 {st['p95_m']:9.2f} m  max {st['max_m']:9.2f} m"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
