"""Benchmark of the identification decoders: passages decoded per second on one core, and
accuracy on generated noisy passages (fixed seeds).

Run: ``.venv/bin/python -m bench.identification`` (about 30 s). Throughput is the best of
three runs, in CPU time of this process (``time.process_time``) so that other load on the
machine does not distort it; wall-clock figures are printed beside it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from identification import em4100, manchester, simulate, time_pulse, wheel_marks

N_SPEED = 3000
N_ACCURACY = 1000
IR: dict[str, Any] = {"query_period_us": 250.0, "reflection_window_us": 50.0, "zone_length_m": 2.0}


def ir_passage(rng: np.random.Generator, **noise: Any) -> tuple[int, dict[str, Any]]:
    car = int(rng.integers(1, 256))
    p = simulate.ir_pulses_passage(car, speed_kmh=float(rng.uniform(5, 15)), rng=rng, **IR, **noise)
    return car, p


def ir_decode(p: dict[str, Any]) -> int | None:
    return time_pulse.decode_passage(
        p["reply_times_us"],
        query_period_us=p["query_period_us"],
        reflection_window_us=p["reflection_window_us"],
    ).car_number


def m_passage(rng: np.random.Generator, **noise: Any) -> tuple[int, dict[str, Any]]:
    car = int(rng.integers(0, 65536))
    clock = float(rng.uniform(-0.05, 0.05))
    return car, simulate.manchester_passage(car, rng=rng, clock_error=clock, **noise)


def m_decode(p: dict[str, Any]) -> int | None:
    return manchester.decode_passage(p["samples"], samples_per_bit=p["samples_per_bit"]).car_number


def w_passage(rng: np.random.Generator, **noise: Any) -> tuple[int, dict[str, Any]]:
    code = int(rng.integers(0, 256))
    direction = int(rng.integers(1, 3))
    return code, simulate.wheel_mark_passage(code, direction=direction, rng=rng, **noise)


def w_decode(p: dict[str, Any]) -> int | None:
    return wheel_marks.decode_passage(p["baseline"], p["axles"], direction=p["direction"]).code


DECODERS: list[tuple[str, Callable[..., tuple[int, dict[str, Any]]], Callable[..., Any], str]] = [
    ("time-pulse (ir_pulses)", ir_passage, ir_decode, "reply_times_us"),
    ("Manchester-II (ir_manchester)", m_passage, m_decode, "samples"),
    ("wheel marks (wheel_marks)", w_passage, w_decode, "axles"),
]

REALISTIC = {
    "time-pulse (ir_pulses)": {"spurious_rate": 0.02, "miss_rate": 0.02, "echo_rate": 0.5},
    "Manchester-II (ir_manchester)": {"flip_prob": 0.01},
    "wheel marks (wheel_marks)": {"fade": 0.7, "noise": 0.1, "impulse": 5.0},
}
HEAVY = {
    "time-pulse (ir_pulses)": {"spurious_rate": 0.3, "miss_rate": 0.2, "echo_rate": 0.9},
    "Manchester-II (ir_manchester)": {"flip_prob": 0.05},
    "wheel marks (wheel_marks)": {"fade": 0.7, "noise": 0.35, "impulse": 5.0},
}


def speed(name: str, make: Callable[..., Any], decode: Callable[..., Any], size_key: str) -> None:
    rng = np.random.default_rng(2026)
    passages = [make(rng, **REALISTIC[name])[1] for _ in range(N_SPEED)]
    size = np.mean([len(p[size_key]) for p in passages])
    best_cpu = best_wall = float("inf")
    for _ in range(3):
        c0, w0 = time.process_time(), time.perf_counter()
        for p in passages:
            decode(p)
        best_cpu = min(best_cpu, time.process_time() - c0)
        best_wall = min(best_wall, time.perf_counter() - w0)
    print(
        f"{name:32s} {N_SPEED / best_cpu:9.0f} passages/s CPU "
        f"({1e6 * best_cpu / N_SPEED:6.1f} µs each; wall {N_SPEED / best_wall:7.0f}/s), "
        f"mean passage {size:.0f} {size_key}"
    )


def accuracy(name: str, make: Callable[..., Any], decode: Callable[..., Any]) -> None:
    for label, noise, seed in (("realistic", REALISTIC[name], 1), ("heavy", HEAVY[name], 2)):
        rng = np.random.default_rng(seed)
        right = wrong = 0
        for _ in range(N_ACCURACY):
            truth, p = make(rng, **noise)
            got = decode(p)
            right += got == truth
            wrong += got is not None and got != truth
        none = N_ACCURACY - right - wrong
        print(
            f"{name:32s} {label:9s} {noise}: right {100 * right / N_ACCURACY:5.1f} %, "
            f"none {100 * none / N_ACCURACY:5.1f} %, wrong {wrong} of {N_ACCURACY}"
        )


def real_traces() -> None:
    folder = Path(__file__).resolve().parents[1].parent / "shared/data/real/manchester_em4102"
    if not folder.is_dir():
        print(f"real EM4102 traces: not found at {folder}")
        return
    for path in sorted(folder.glob("*.pm3")):
        signal = em4100.load_pm3(path)
        t0 = time.perf_counter()
        r = em4100.decode_trace(signal)
        ms = 1e3 * (time.perf_counter() - t0)
        print(
            f"real {path.name:26s} id {r.tag_id}  frames {r.frames_ok}  "
            f"bit period {r.samples_per_bit_estimate:.2f} samples  "
            f"({ms:.0f} ms, {signal.size} samples)"
        )


def main() -> None:
    print(f"== throughput, {N_SPEED} passages each, one core")
    for name, make, decode, key in DECODERS:
        speed(name, make, decode, key)
    print(f"== accuracy, {N_ACCURACY} generated passages each (fixed seeds)")
    for name, make, decode, _ in DECODERS:
        accuracy(name, make, decode)
    print("== real Manchester-II signals (proxmark3 EM4102 traces)")
    real_traces()


if __name__ == "__main__":
    main()
