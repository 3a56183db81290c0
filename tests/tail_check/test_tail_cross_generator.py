"""Cross-generator accuracy of the tail check and no `present` on real photos (issue 11).

The verifier used on generator A's scenes was trained on generator B only (plus the
``train`` part of the real photos as negatives), and the other way round, so these
figures are on scenes of a kind the model never saw. The scenes are the first
``COUNT`` held-out seeds of each generator (the same seeds ``python -m
bench.tail_accuracy`` reports on, which has all 150); they are cached as PNG under
``var/tail_cache`` because generator B takes about a second per scene.

Two variants: ``learned`` (the staged pipeline alone) and ``guarded`` (the hand-tuned
verdict, which the verifier may only question). Measured on these seeds: see
``EXPECTED``; on all 150 held-out seeds per generator see the module docstring of
:mod:`bench.tail_accuracy` and the issue's closing note. The issue's targets (>= 95 %
correct cross-generator) are NOT met on generator B; the floors sit a little under
the measured values. The safety property (no false `present`) is asserted exactly.

Models of branch ``tail-accuracy3`` (generator A trained on its randomised mode with
lamps among the hard negatives): generator B's tail lamps, signals and red lettering
are no longer called ``present`` by A's model, but its discs mostly stay ``uncertain``
or ``absent`` (learned, B's scenes with A's model: 43 % on these 30 seeds, 53.3 % on
the unused held-out seeds 300300-300599).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tail_check import detect
from tail_check.dataset import Sample, real_dir, real_photos, scenes
from tail_check.evaluate import Tally
from tail_check.pipeline import (
    PIPELINE_PROFILE,
    VerdictParams,
    find_candidates,
    judge,
    load_model,
    run_pipeline,
)

COUNT = 30
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


VARIANTS = ("learned", "guarded")


def _judged(samples: list[Sample], models: tuple[str, ...]) -> dict[tuple[str, str], Tally]:
    """Tallies per (model, variant); candidates and the hand-tuned verdict computed once
    per sample, then judged by every model (the same code path as ``run_pipeline``)."""
    out = {(m, v): Tally() for m in models for v in VARIANTS}
    loaded = {m: load_model(m) for m in models}
    for s in samples:
        cands = find_candidates(s.image, PIPELINE_PROFILE)[0]
        hand = detect(s.image).verdict
        for (m, v), result in out.items():
            verdict = judge(cands, loaded[m], VerdictParams(combine=v), hand)[0]  # type: ignore[arg-type]
            result.add(s, verdict)
    return out


EXPECTED = {
    ("A", "learned"): (0.70, 0.63),
    ("B", "learned"): (0.43, 0.36),
    ("A", "guarded"): (0.90, 0.83),
    ("B", "guarded"): (0.50, 0.43),
}
"""(measured share correct, floor asserted) per generator and variant on these seeds."""


@pytest.mark.parametrize("generator", ["A", "B"])
def test_cross_generator_no_false_present_and_accuracy(generator: str) -> None:
    other = "B" if generator == "A" else "A"
    samples = list(scenes(generator, "heldout", COUNT))  # type: ignore[arg-type]
    for (_, variant), result in _judged(samples, (other,)).items():
        print("\n".join(result.lines(f"{variant}: generator {generator}, trained on {other}")))
        assert result.overall.total == COUNT
        assert result.overall.false_present == 0, (variant, result.false_present_names)
        measured, floor = EXPECTED[(generator, variant)]
        assert result.overall.correct >= floor, (variant, result.overall.summary(), measured)


@pytest.mark.xfail(
    strict=True,
    reason="known false present of the hand-tuned detector alone; the service's verdict is"
    " confirmed by the learned verifier, which holds it uncertain (test_tail_confirm.py)",
)
def test_hand_tuned_detector_alone_calls_a_hand_wheel_a_disc() -> None:
    sample = next(scenes("A", "heldout", 1, offset=44))
    assert not sample.disc and sample.kind == "hand_wheel"
    assert detect(sample.image).verdict != "present"


def test_guarded_verifier_questions_that_hand_wheel() -> None:
    sample = next(scenes("A", "heldout", 1, offset=44))
    guarded = VerdictParams(combine="guarded")
    for name in ("B", "AB"):
        assert run_pipeline(sample.image, model=load_model(name), params=guarded).verdict != (
            "present"
        )


def test_no_present_on_real_photos() -> None:
    photos = list(real_photos("report")) + list(real_photos("train"))
    if not photos:
        pytest.skip(f"real photos not found under {real_dir()} (set DEPOT_REAL_DATA_DIR)")
    for (model, variant), result in _judged(photos, ("AB", "A", "B")).items():
        assert result.overall.by_verdict("present") == 0, (model, variant, result.overall.summary())


def test_real_photos_are_split_in_two_disjoint_halves() -> None:
    report = {s.name for s in real_photos("report")}
    train = {s.name for s in real_photos("train")}
    if not report:
        pytest.skip(f"real photos not found under {real_dir()}")
    assert report.isdisjoint(train)
    assert report | train == {s.name for s in real_photos()}
    assert abs(len(report) - len(train)) <= len(("railsem19_frames", "red_wagons"))
    with pytest.raises(ValueError, match="part"):
        next(real_photos("test"))  # type: ignore[arg-type]


def test_hand_tuned_detector_never_calls_a_lit_lamp_a_disc() -> None:
    """Generator B's seed 300535: a lit electric tail lamp mid-body at dusk (a clipped
    core fading out in a glow, see :mod:`tail_check.lamps`)."""
    sample = next(scenes("B", "heldout", 1, offset=535))
    assert not sample.disc and sample.kind == "tail_lamp" and sample.condition == "dusk"
    result = detect(sample.image)
    assert result.verdict == "uncertain" and "lit lamp" in result.reasons[0]


@pytest.mark.xfail(
    strict=True,
    reason="known false present of the hand-tuned detector alone on generator B's"
    " held-out seed 300498: a lit signal head beside the track at dusk, 13 working pixels"
    " across. Its glow is as narrow as the blurred outline of a disc that size (1.9 working"
    " pixels; discs with a shining reflector measure 1.7-3.3), so the lamp check cannot tell"
    " it from the small lit discs it must keep (issue 11); the service's verdict is confirmed by"
    " the learned verifier, which holds it uncertain (test_tail_confirm.py)",
)
def test_hand_tuned_detector_never_calls_a_small_lit_signal_a_disc() -> None:
    sample = next(scenes("B", "heldout", 1, offset=498))
    assert not sample.disc and sample.kind == "signal_light" and sample.condition == "dusk"
    assert detect(sample.image).verdict != "present"
