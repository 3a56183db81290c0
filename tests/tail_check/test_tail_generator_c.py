"""The service's tail verdict on generator C, which nothing was trained or tuned on.

Generator C (:mod:`tail_check.scenes_c`) was written by a helper who read neither
generator A nor B nor the detector. No verifier is trained on it (training refuses it)
and no threshold was chosen on it, so these figures are what a new camera's scenes get.
Measured on its first 60 held-out seeds (300000-300059): the hand-tuned detector alone
65.0 % correct, 15.0 % uncertain; the service's verdict (every ``present`` confirmed by
every verifier) 60.0 % correct, 20.0 % uncertain, 0 false ``present``; 7 of 28 discs
``present``, 12 ``absent``. The issue's >= 95 % is NOT met; the safety property (no
false ``present``) is asserted exactly, the accuracy a little under what was measured.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tail_check import detect_confirmed
from tail_check.dataset import scenes
from tail_check.evaluate import tally
from tail_check.pipeline.train import train

ROOT = Path(__file__).resolve().parents[2]
COUNT = 60
MEASURED_CORRECT = 0.60
"""Share of the 60 scenes the service's verdict gets right (measured)."""


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


def test_the_service_never_calls_a_scene_of_generator_c_without_a_disc_present() -> None:
    result = tally(scenes("C", "heldout", COUNT), lambda s: detect_confirmed(s.image).verdict)
    print("\n".join(result.lines("service verdict: generator C")))
    overall = result.overall
    assert overall.total == COUNT
    assert overall.false_present == 0, result.false_present_names
    assert overall.correct >= MEASURED_CORRECT - 0.05, overall.summary()
    # Some of C's discs are found, so the figure is not "absent" everywhere.
    assert result.by_kind["disc"].by_verdict("present") >= 5, overall.summary()


def test_no_verifier_is_trained_on_generator_c() -> None:
    with pytest.raises(ValueError, match="generator C is kept for evaluation"):
        train(("C",), seed=1)
    with pytest.raises(ValueError, match="generator C is kept for evaluation"):
        train(("A", "C"), seed=1)
