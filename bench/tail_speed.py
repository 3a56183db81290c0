"""Benchmark of the tail-disc detector: time per 1920x1080 JPEG snapshot, one core.

Prints median and p99 latency of decode + detect (full decode, and
``detect_snapshot``: the JPEG decoder's DCT-domain reduction), the detector alone, the
decode alone, and
connected-components labelling in OpenCV's default vs CCL_GRANA / 16-bit labels.
Run: .venv/bin/python -m bench.tail_speed
"""

from __future__ import annotations

import statistics
import time
from collections import Counter
from collections.abc import Callable, Iterable
from typing import Any

# This script is named like the package; keep its folder off the import path.
import cv2
import numpy as np

from tail_check import decode_snapshot, detect, detect_snapshot
from tail_check.synth import iter_snapshots

cv2.setNumThreads(1)  # one core, as the target states
COUNT = 60
SIZE = (1920, 1080)


def _stats(name: str, samples: list[float]) -> None:
    ms = sorted(1000 * s for s in samples)
    p99 = ms[min(len(ms) - 1, int(round(0.99 * (len(ms) - 1))))]
    print(f"{name:42s} p50 {statistics.median(ms):6.2f} ms   p99 {p99:6.2f} ms   (n={len(ms)})")


def _time(fn: Callable[[Any], object], items: Iterable[Any]) -> list[float]:
    out: list[float] = []
    for item in items:
        t0 = time.perf_counter()
        fn(item)
        out.append(time.perf_counter() - t0)
    return out


def main() -> None:
    t0 = time.perf_counter()
    jpegs, labels = [], []
    for image, label in iter_snapshots(77, COUNT, size=SIZE):
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])
        assert ok
        jpegs.append(buf.tobytes())
        labels.append(label)
    print(f"generated {COUNT} snapshots {SIZE[0]}x{SIZE[1]} in {time.perf_counter() - t0:.1f} s")
    decoded = [decode_snapshot(j) for j in jpegs]
    for _ in range(3):  # warm-up
        detect(decoded[0])
    _stats("decode only (full)", _time(decode_snapshot, jpegs))
    _stats("decode only (2x reduced)", _time(lambda j: decode_snapshot(j, reduce=2), jpegs))
    _stats("detect only (1920x1080 array)", _time(detect, decoded))
    _stats("decode + detect (full decode)", _time(lambda j: detect(decode_snapshot(j)), jpegs))
    _stats("detect_snapshot (reduced decode + detect)", _time(detect_snapshot, jpegs))

    confusion: Counter[tuple[str, str]] = Counter()
    for j, label in zip(jpegs, labels, strict=True):
        truth = "present" if label.disc else "absent"
        confusion[(truth, detect_snapshot(j).verdict)] += 1
    correct = confusion[("present", "present")] + confusion[("absent", "absent")]
    print(
        f"verdicts on these {COUNT}: {dict(sorted(confusion.items()))}; correct {correct}/{COUNT}"
    )

    noise = (np.random.default_rng(0).random((1080, 1920)) > 0.7).astype(np.uint8)
    mask = cv2.morphologyEx(noise, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    for name, fn in (
        ("CC with stats, default", lambda m: cv2.connectedComponentsWithStats(m, connectivity=8)),
        (
            "CC with stats, GRANA, 32-bit labels",
            lambda m: cv2.connectedComponentsWithStatsWithAlgorithm(
                m, 8, cv2.CV_32S, cv2.CCL_GRANA
            ),
        ),
        (
            "CC with stats, GRANA, 16-bit labels",
            lambda m: cv2.connectedComponentsWithStatsWithAlgorithm(
                m, 8, cv2.CV_16U, cv2.CCL_GRANA
            ),
        ),
    ):
        _stats(f"{name} (1920x1080 mask)", _time(fn, [mask] * 20))


if __name__ == "__main__":
    main()
