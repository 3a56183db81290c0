"""Cross-generator accuracy of the tail check and no `present` on real photos (issue 11).

The verifier used on generator A's scenes was trained on generator B only, and the
other way round, so these figures are on scenes of a kind the model never saw. The
scenes are the first ``COUNT`` held-out seeds of each generator (the same seeds
``python -m bench.tail_accuracy`` reports on, with more of them); they are cached as
PNG under ``var/tail_cache`` because generator B takes about a second per scene.

Expected on these seeds (measured, guarded pipeline = hand-tuned detector with the
learned verifier able only to veto a `present` or to raise an `absent` to `uncertain`):
A (verifier trained on B): 95.8 % correct (disc 9/1/0 present/uncertain/absent, no disc
0/0/14); B (verifier trained on A): 50.0 % correct (disc 0/3/9, no disc 0/0/12). The
issue's target (>= 95 % cross-generator) is NOT met on B: most of B's discs give no
disc-shaped region to the hand-tuned detector. The safety property (no false `present`)
is asserted exactly; the accuracy floors sit a few points under the measured value. On
150 held-out seeds one false `present` remains (a hand wheel, A seed 300044): see the
strict xfail below.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tail_check.dataset import Sample, real_dir, real_photos, scenes
from tail_check.evaluate import Tally, tally
from tail_check.pipeline import load_model, run_pipeline

COUNT = 24
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


def _cross(generator: str) -> Tally:
    other = "B" if generator == "A" else "A"
    model = load_model(other)

    def verdict(s: Sample) -> str:
        return run_pipeline(s.image, model=model).verdict

    result = tally(scenes(generator, "heldout", COUNT), verdict)  # type: ignore[arg-type]
    print("\n".join(result.lines(f"generator {generator}, verifier trained on {other}")))
    return result


EXPECTED = {"A": (0.958, 0.90), "B": (0.50, 0.45)}
"""(measured share correct, floor asserted) per generator on these seeds."""


@pytest.mark.parametrize("generator", ["A", "B"])
def test_cross_generator_no_false_present_and_accuracy(generator: str) -> None:
    result = _cross(generator)
    assert result.overall.total == COUNT
    assert result.overall.false_present == 0, result.false_present_names
    measured, floor = EXPECTED[generator]
    assert result.overall.correct >= floor, (result.overall.summary(), measured)


@pytest.mark.xfail(strict=True, reason="known false present: a hand wheel (A seed 300044)")
def test_known_false_present_on_a_hand_wheel() -> None:
    sample = next(scenes("A", "heldout", 1, offset=44))
    assert not sample.disc and sample.kind == "hand_wheel"
    assert run_pipeline(sample.image, model=load_model("B")).verdict != "present"


@pytest.mark.parametrize("model_name", ["AB", "A", "B"])
def test_no_present_on_real_photos(model_name: str) -> None:
    photos = list(real_photos())
    if not photos:
        pytest.skip(f"real photos not found under {real_dir()} (set DEPOT_REAL_DATA_DIR)")
    model = load_model(model_name)
    present = [s.name for s in photos if run_pipeline(s.image, model=model).verdict == "present"]
    assert present == []
