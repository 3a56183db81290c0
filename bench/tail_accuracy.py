"""Accuracy of the tail-disc detector: confusion matrices that cannot fool themselves.

For each detector variant it prints the confusion (present/uncertain/absent vs truth)
overall, per condition and per hard-negative kind on

(a) each generator's held-out seeds (the generator a learned verifier was trained on),
(b) the cross-generator split (trained on one generator, evaluated on the other),
(c) every real photo (``DEPOT_REAL_DATA_DIR``; none shows a disc).

The hand-tuned detector has no training, so for it (a) and (b) are the same scenes.
Rendered scenes are cached under ``var/tail_cache`` (``DEPOT_TAIL_CACHE``).

Run: ``.venv/bin/python -m bench.tail_accuracy [--count N] [--variant NAME ...]``
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import cv2

from tail_check import detect
from tail_check.dataset import Sample, real_dir, real_photos, scenes
from tail_check.evaluate import tally

cv2.setNumThreads(1)
Verdictor = Callable[[Sample], str]


def _baseline(sample: Sample) -> str:
    return detect(sample.image).verdict


def _variants(names: list[str]) -> dict[str, dict[str, Verdictor]]:
    """Per variant: the verdict function to use on scenes of A, of B and on real photos."""
    out: dict[str, dict[str, Verdictor]] = {}
    for name in names:
        if name == "baseline":
            out[name] = {"A": _baseline, "B": _baseline, "real": _baseline}
        elif name == "pipeline":
            from tail_check.pipeline import load_model, run_pipeline

            trained_a, trained_b = load_model("A"), load_model("B")

            # Scenes of A are judged by the model trained on B and the other way round;
            # the shipped model (trained on both) judges the real photos.
            def on_a(s: Sample) -> str:
                return run_pipeline(s.image, model=trained_b).verdict

            def on_b(s: Sample) -> str:
                return run_pipeline(s.image, model=trained_a).verdict

            def on_real(s: Sample) -> str:
                return run_pipeline(s.image).verdict

            out[name] = {"A": on_a, "B": on_b, "real": on_real}
        else:
            raise SystemExit(f"unknown variant {name!r}; use baseline or pipeline")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=150, help="held-out scenes per generator")
    parser.add_argument("--variant", nargs="+", default=["baseline", "pipeline"])
    args = parser.parse_args(argv)
    os.environ.setdefault("DEPOT_TAIL_CACHE", "var/tail_cache")
    t0 = time.perf_counter()
    held = {g: list(scenes(g, "heldout", args.count)) for g in ("A", "B")}
    photos = list(real_photos())
    print(f"scenes ready in {time.perf_counter() - t0:.0f} s; real photos: {len(photos)}")
    if not photos:
        print(f"  (no real photos under {real_dir()}; set DEPOT_REAL_DATA_DIR)")
    for variant, judge in _variants(args.variant).items():
        for g in ("A", "B"):
            other = "B" if g == "A" else "A"
            how = "no training" if variant == "baseline" else f"verifier trained on {other}"
            print("\n".join(tally(held[g], judge[g]).lines(f"{variant}: generator {g} ({how})")))
        if photos:
            print("\n".join(tally(photos, judge["real"]).lines(f"{variant}: real photos")))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
