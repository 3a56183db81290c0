"""Speed of the tail check on 1920x1080 JPEG snapshots, one core, as ratios.

Measured side by side in one run, interleaved per image so that the machine's load
hits every variant alike: JPEG decode alone, and decode + detect for the hand-tuned
detector, the learned pipeline alone (proposals + features + verifier; it works at a
320-pixel scale, so the JPEG decoder's 4x DCT-domain reduction still gives it more
pixels than it uses) and the guarded combination (hand-tuned + learned), with the full
and reduced decodes. The figure the issue asks for is ``decode + detect p50 / full
decode p50``.

Run: ``.venv/bin/python -m bench.tail_check [COUNT]``
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable

import cv2

from tail_check import decode_snapshot, detect
from tail_check.pipeline import VerdictParams, load_model, run_pipeline
from tail_check.synth import iter_snapshots

cv2.setNumThreads(1)  # one core, as the target states
SIZE = (1920, 1080)
QUALITY = 90


def _timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main(argv: list[str]) -> int:
    count = int(argv[1]) if len(argv) > 1 else 40
    jpegs = []
    for image, _label in iter_snapshots(77, count, size=SIZE):
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, QUALITY])
        assert ok
        jpegs.append(buf.tobytes())
    model = load_model()
    guarded = VerdictParams(combine="guarded")
    variants: dict[str, Callable[[bytes], object]] = {
        "decode (full)": decode_snapshot,
        "decode (2x reduced)": lambda j: decode_snapshot(j, reduce=2),
        "decode + hand-tuned detect": lambda j: detect(decode_snapshot(j)),
        "decode 2x + hand-tuned detect": lambda j: detect(decode_snapshot(j, reduce=2)),
        "decode (4x reduced)": lambda j: decode_snapshot(j, reduce=4),
        "decode + learned": lambda j: run_pipeline(decode_snapshot(j), model=model),
        "decode 2x + learned": lambda j: run_pipeline(decode_snapshot(j, reduce=2), model=model),
        "decode 4x + learned": lambda j: run_pipeline(decode_snapshot(j, reduce=4), model=model),
        "decode 2x + guarded": lambda j: run_pipeline(
            decode_snapshot(j, reduce=2), model=model, params=guarded
        ),
    }
    for fn in variants.values():  # warm-up
        fn(jpegs[0])
    samples: dict[str, list[float]] = {name: [] for name in variants}
    for j in jpegs:
        for name, fn in variants.items():
            samples[name].append(_timed(lambda fn=fn, j=j: fn(j)))  # type: ignore[misc]
    p50 = {name: statistics.median(s) for name, s in samples.items()}
    base = p50["decode (full)"]
    print(f"{count} JPEG snapshots {SIZE[0]}x{SIZE[1]} q{QUALITY}, one core; p50 per image")
    for name, value in p50.items():
        print(f"  {name:32s} p50 {1000 * value:7.2f} ms   ratio to full decode {value / base:5.2f}")
    for name in ("decode 4x + learned", "decode 2x + guarded"):
        print(f"{name} / full decode alone: {p50[name] / base:.2f} (target <= 1.5)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
