"""Where do the true discs of a generator go? Each disc scene attributed to the stage that
lost it, so the next change aims at the stage that costs most.

For every scene with a disc (a generator's dev seeds: validation split, offset 60000 by
default, never a held-out seed the accuracy bench reports):

* ``outside region``: the disc's centre lies outside the default profile's search region
  (an uncalibrated camera's; the hand-tuned detector never looks there);
* the hand-tuned verdict (``present``, ``uncertain``, ``absent``);
* the service's verdict, and for a held ``present`` what held it (lettering, roundel,
  housing, pair, the learned verifiers);
* whether the learned stages propose a candidate on the disc at all, and how close the
  least convinced verifier comes: its probability over its confirming threshold
  (``uncertain_threshold``, what a hand-tuned ``present`` needs) and over its ``present``
  threshold (what the learned stages alone would need to answer ``present``).

Measured once (2026-12-07), disc scenes of validation seeds 260000-260159 of B (78) and
260000-260299 of C (142): the learned stages propose a candidate on the disc for 71 of B's
and 140 of C's, but every verifier reaches its ``present`` threshold on 3 and 1 of them
(its confirming threshold on 21 and 64): the verifiers, not the proposals, limit recall.
The hand-tuned detector calls 48 of B's and 62 of C's ``absent``; 8 and 30 of the discs lie
outside the default search region. Of the hand-tuned ``present`` (17, 54) the verifiers
hold 8 and 16 ``uncertain``; the service finds 9 and 38.

Run: ``.venv/bin/python -m bench.tail_recall [--generator C] [--count 150] [--offset 60000]``
"""

from __future__ import annotations

import argparse
from collections import Counter

import cv2
import numpy as np

from tail_check import detect
from tail_check.confirm import CONFIRM_PARAMS, confirm, hold_lookalikes
from tail_check.dataset import GENERATORS, Sample, scenes
from tail_check.pipeline import PIPELINE_PROFILE, find_candidates, load_model
from tail_check.pipeline.train import TrainParams, matches
from tail_check.profile import DEFAULT_PROFILE

cv2.setNumThreads(1)
HELD_BY = {
    "letter": "lettering",
    "roundel": "roundel",
    "lettering inside": "roundel",
    "housing": "housing",
    "twin": "pair",
    "learned verifiers": "verifiers",
}
"""A word of the holding reason -> the check that held a hand-tuned ``present``."""


def _outside(s: Sample) -> bool:
    assert s.bbox is not None
    x, y, w, h = s.bbox
    height, width = s.image.shape[:2]
    x0, y0, x1, y1 = DEFAULT_PROFILE.search_region
    cx, cy = (x + w / 2) / width, (y + h / 2) / height
    return not (x0 <= cx <= x1 and y0 <= cy <= y1)


def _held_by(reason: str) -> str:
    return next((name for word, name in HELD_BY.items() if word in reason), "other")


def _learned(s: Sample) -> tuple[float, float] | None:
    """Least convinced verifier's probability over its confirming and its present
    threshold, on the best candidate on the disc; None when none is proposed there."""
    models = [load_model(name) for name in CONFIRM_PARAMS.models]
    on_disc = [
        c
        for c in find_candidates(s.image, PIPELINE_PROFILE)[0]
        if matches(c, s.bbox, TrainParams())
    ]
    if not on_disc:
        return None
    x = np.stack([c.features for c in on_disc])
    probs = np.stack([m.probability(x) for m in models])  # (models, candidates)
    confirm_at = np.array([[float(m.meta["uncertain_threshold"])] for m in models])
    present_at = np.array([[float(m.meta["present_threshold"])] for m in models])
    return float((probs / confirm_at).min(axis=0).max()), float(
        (probs / present_at).min(axis=0).max()
    )


def attribute(samples: list[Sample]) -> Counter[str]:
    """Counts of each stage's outcome over the disc scenes of ``samples``."""
    out: Counter[str] = Counter()
    for s in samples:
        if not s.disc:
            continue
        out["discs"] += 1
        out["outside region"] += _outside(s)
        hand = detect(s.image)
        service = confirm(s.image, hand)
        out[f"hand {hand.verdict}"] += 1
        out[f"service {service.verdict}"] += 1
        if hand.verdict == "present" and service.verdict != "present":
            held = hold_lookalikes(s.image, hand)
            out[f"held by {_held_by((held if held is not hand else service).reasons[0])}"] += 1
        learned = _learned(s)
        if learned is None:
            out["no learned candidate on the disc"] += 1
            continue
        out["learned candidate on the disc"] += 1
        out["every verifier would confirm it"] += learned[0] >= 1.0
        out["every verifier would call it present"] += learned[1] >= 1.0
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generator", choices=GENERATORS, default="C")
    parser.add_argument("--count", type=int, default=150, help="scenes (with and without a disc)")
    parser.add_argument("--offset", type=int, default=60_000, help="into the validation split")
    args = parser.parse_args(argv)
    samples = list(scenes(args.generator, "validation", args.count, offset=args.offset))
    counts = attribute(samples)
    print(f"generator {args.generator}, validation seeds offset {args.offset}, {args.count} scenes")
    for key, value in sorted(counts.items()):
        print(f"  {key:40s} {value:5d}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
