"""Speed of the tail check on 1920x1080 JPEG snapshots, one core, as ratios.

Measured side by side in one run, interleaved per image so that the machine's load
hits every variant alike; per image and variant the best of ``REPEAT`` calls (the
machine is shared: a call that lost the core to another process says nothing about
the code), then the median over the images; also the same from each call's CPU time
(``time.thread_time``: on a loaded machine the wall time of a long call grows with the
chance that it loses the core, so wall ratios grow with the load). The figure the
issue asks for is

    ratio = p50(decode + detect) / p50(JPEG decode alone)

with ``decode + detect`` = :func:`tail_check.detect_snapshot` (the service's path: the
JPEG decoder reduces in the DCT domain as far as the working scale allows; a ``present``
is then confirmed by the learned verifier, :func:`tail_check.confirm`) and the decode
alone = a full decode (:func:`tail_check.decode_snapshot`). Also shown: the same without
the verifier's check (it runs on ``present`` verdicts only, and most of these snapshots
show a disc), the old path (full decode, then :func:`tail_check.detect`), the reduced
decode alone, and with ``--learned`` the learned pipeline and the guarded combination.

Run: ``.venv/bin/python -m bench.tail_check [--count N] [--learned]``
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import cv2

from tail_check import ConfirmParams, decode_snapshot, detect, detect_snapshot
from tail_check.snapshot import reduction_for
from tail_check.synth import iter_snapshots

cv2.setNumThreads(1)  # one core, as the target states
SIZE = (1920, 1080)
QUALITY = 90
REPEAT = 3
TARGET = 1.5
UNCONFIRMED = ConfirmParams(enabled=False)
"""The hand-tuned detector's verdict without the learned verifier's check of a ``present``
(the service's path before issue 11's check; shown for the cost of the check)."""


def _calls(fn: Callable[[bytes], object], data: bytes) -> tuple[list[float], list[float]]:
    """Wall and CPU (this thread's) seconds of each of ``REPEAT`` calls."""
    wall, cpu = [], []
    for _ in range(REPEAT):
        c0, t0 = time.thread_time(), time.perf_counter()
        fn(data)
        wall.append(time.perf_counter() - t0)
        cpu.append(time.thread_time() - c0)
    return wall, cpu


def _variants(learned: bool) -> dict[str, Callable[[bytes], object]]:
    factor = reduction_for(SIZE)
    variants: dict[str, Callable[[bytes], object]] = {
        "decode (full)": decode_snapshot,
        f"decode (1/{factor}, DCT domain)": lambda j: decode_snapshot(j, reduce=factor),
        "detect_snapshot (decode + detect)": detect_snapshot,
        "  the same, hand-tuned only": lambda j: detect_snapshot(j, confirmed=UNCONFIRMED),
        "full decode + detect (old path)": lambda j: detect(decode_snapshot(j)),
    }
    if learned:
        from tail_check.pipeline import VerdictParams, load_model, run_pipeline

        model = load_model()
        guarded = VerdictParams(combine="guarded")
        variants["decode 1/4 + learned"] = lambda j: run_pipeline(
            decode_snapshot(j, reduce=4), model=model
        )
        variants["decode 1/2 + guarded"] = lambda j: run_pipeline(
            decode_snapshot(j, reduce=2), model=model, params=guarded
        )
    return variants


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=40, help="snapshots (default 40)")
    parser.add_argument("--learned", action="store_true", help="also the learned pipeline")
    args = parser.parse_args(argv)
    jpegs = []
    for image, _label in iter_snapshots(77, args.count, size=SIZE):
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, QUALITY])
        assert ok
        jpegs.append(buf.tobytes())
    variants = _variants(args.learned)
    for fn in variants.values():  # warm-up
        fn(jpegs[0])
    calls: dict[str, list[list[float]]] = {name: [] for name in variants}
    cpu: dict[str, list[list[float]]] = {name: [] for name in variants}
    for j in jpegs:
        for name, fn in variants.items():
            wall, used = _calls(fn, j)
            calls[name].append(wall)
            cpu[name].append(used)
    # p50 of every call, p50 over images of each image's fastest call, and the same of
    # the CPU time (what a call costs the core, without the time others held it).
    p50 = {n: statistics.median(t for c in cs for t in c) for n, cs in calls.items()}
    best = {n: statistics.median(min(c) for c in cs) for n, cs in calls.items()}
    best_cpu = {n: statistics.median(min(c) for c in cs) for n, cs in cpu.items()}
    print(f"{args.count} JPEG snapshots {SIZE[0]}x{SIZE[1]} q{QUALITY}, one core, {REPEAT} calls")
    print("each, variants interleaved per image; ratios to the full decode in the same run")
    print(f"  {'':36s} {'p50 all calls':>22s}   {'p50 of best per image':>26s}   {'CPU':>18s}")
    full = "decode (full)"
    for name in variants:
        a, b, c = p50[name], best[name], best_cpu[name]
        print(
            f"  {name:36s} {1000 * a:7.2f} ms  x{a / p50[full]:5.2f}"
            f"   {1000 * b:7.2f} ms  x{b / best[full]:5.2f}"
            f"   {1000 * c:7.2f} ms  x{c / best_cpu[full]:5.2f}"
        )
    key = "detect_snapshot (decode + detect)"
    tables = (("p50 all calls", p50), ("p50 of best per image", best), ("CPU, best", best_cpu))
    for label, table in tables:
        ratio = table[key] / table["decode (full)"]
        verdict = "met" if ratio <= TARGET else "NOT met"
        print(f"(decode + detect) / decode, {label}: {ratio:.2f} (target <= {TARGET}: {verdict})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
