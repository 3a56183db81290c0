"""A hand-tuned `present` must be confirmed by the learned verifier (issue 11).

Every known false `present` of the hand-tuned detector (a hand wheel, lit signals, tail
lamps, a road vehicle's tail lights; from both generators, held-out and tuning seeds) is
held `uncertain` by the service's path (``detect_snapshot``, ``confirm``), while the
hand-tuned detector alone still calls each a disc, so the test shows what the check adds.
True discs mostly stay `present`: the share is asserted on generator A's tuning seeds.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

import tail_check.pipeline.candidates as candidates_stage
from tail_check import ConfirmParams, confirm, detect, detect_snapshot
from tail_check.confirm import CONFIRM_PARAMS, confirm_with
from tail_check.dataset import SPLITS, Sample, scenes
from tail_check.detect import DetectionResult
from tail_check.pipeline import PIPELINE_PROFILE, find_candidates, load_model
from tests.tail_check.tailkit import hand_presents_on_discs

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


def _scene(generator: str, split: str, offset: int) -> Sample:
    return next(scenes(generator, split, 1, offset=offset))  # type: ignore[arg-type]


def _jpeg(image: NDArray[np.uint8]) -> bytes:
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 92])
    assert ok
    return buf.tobytes()


HAND_TUNED_FALSE_PRESENTS = [
    ("A", "heldout", 44, "hand_wheel"),
    ("B", "heldout", 498, "signal_light"),
    ("B", "heldout", 30084, "signal_light"),
    ("A", "heldout_wide", 30108, "tail_lamp"),
    ("A", "heldout_wide", 30168, "road_tail_lights"),
    # A lit lamp on a red car in snow (the scene's first distractor is a red square);
    # the verifier trained on both generators believed it (0.79), the one trained on A not
    # (0.21), so every verifier must believe a region.
    ("A", "heldout_wide", 20037, "red_square"),
]


@pytest.mark.parametrize(("generator", "split", "offset", "kind"), HAND_TUNED_FALSE_PRESENTS)
def test_a_lamp_or_wheel_the_hand_tuned_detector_calls_a_disc_is_held_uncertain(
    generator: str, split: str, offset: int, kind: str
) -> None:
    sample = _scene(generator, split, offset)
    assert not sample.disc and sample.kind == kind
    hand = detect(sample.image)
    assert hand.verdict == "present"  # the error the check exists for
    checked = confirm(sample.image, hand)
    assert checked.verdict == "uncertain"
    assert "learned verifiers doubt it" in checked.reasons[0]
    assert "a person must look" in checked.reasons[0]
    assert all(f"{name} 0." in checked.reasons[0] for name in CONFIRM_PARAMS.models)
    assert checked.reasons[1:] == hand.reasons and checked.bbox == hand.bbox
    # the service's path (reduced JPEG decode) gives the same answer
    assert detect_snapshot(_jpeg(sample.image)).verdict == "uncertain"


def test_only_a_present_is_checked_and_nothing_becomes_present() -> None:
    plain = _scene("A", "heldout", 1)
    result = detect(plain.image)
    for verdict in ("absent", "uncertain"):
        given = replace(result, verdict=verdict)
        assert confirm(plain.image, given) is given
    disc = next(s for s in scenes("A", "heldout", 20) if s.disc)
    hand = detect(disc.image)
    assert hand.verdict == "present"
    assert confirm(disc.image, hand, ConfirmParams(enabled=False)) is hand


def test_a_present_without_a_verifier_candidate_on_its_region_is_held_uncertain() -> None:
    """The verifier speaks only for the region the hand-tuned detector named: a box moved
    onto plain ballast has no candidate there, so the present is not confirmed."""
    disc = next(s for s in scenes("A", "heldout", 20) if s.disc)
    hand = detect(disc.image)
    width, height = hand.image_size
    elsewhere = replace(hand, bbox=(2, height - 12, 10, 10))
    assert confirm(disc.image, elsewhere).verdict == "uncertain"


def test_the_box_is_scaled_to_the_image_the_result_is_confirmed_on() -> None:
    disc = next(s for s in scenes("A", "heldout", 20) if s.disc)
    hand = detect(disc.image)
    half = np.asarray(
        cv2.resize(disc.image, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA), np.uint8
    )
    assert confirm(disc.image, hand).verdict == "present"
    assert confirm(half, hand).verdict == "present"  # hand's box is in full-size pixels


MEASURED_KEPT = 75 / 84
"""Of the hand-tuned detector's ``present`` on true discs of generator A's tuning seeds
330000-330199 (reference mode), the share every verifier confirms (measured; 77 of 84
when the one trained on both generators alone was asked)."""


def test_most_true_discs_stay_present() -> None:
    kept = total = 0
    for sample, hand in hand_presents_on_discs(scenes("A", "heldout", 200, offset=30000)):
        total += 1
        kept += confirm(sample.image, hand).verdict == "present"
    assert total == 84
    assert kept / total >= MEASURED_KEPT - 0.02, (kept, total)


def _confirmed_on_every_candidate(
    image: NDArray[np.uint8], hand: DetectionResult
) -> DetectionResult:
    """:func:`confirm` judging every candidate of the whole frame at once, as the
    verifiers were trained and calibrated on them (and as ``bench.tail_accuracy``
    judges): the strongest ``max_candidates``, merged."""
    candidates, _ = find_candidates(image, PIPELINE_PROFILE)
    return confirm_with(candidates, 1.0, hand, [load_model(m) for m in CONFIRM_PARAMS.models])


def test_the_service_judges_the_candidates_the_verifiers_were_calibrated_on() -> None:
    """Generator C's fresh seed 380229 (a lit signal at dusk): when only the proposals
    near the region were described, a weak one that the whole frame's strongest 24 leave
    out was believed by every verifier, and the service said ``present`` where the
    benchmark, judging the whole frame's candidates, said ``uncertain``."""
    sample = _scene("C", "heldout", 80229)
    assert not sample.disc and sample.kind == "signal_light"
    hand = detect(sample.image)
    assert hand.verdict == "present"
    assert confirm(sample.image, hand) == _confirmed_on_every_candidate(sample.image, hand)
    assert confirm(sample.image, hand).verdict == "uncertain"


def test_confirming_stops_describing_once_the_verifier_believes_a_candidate(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Describing candidates is most of the check's time; once one near the region is
    believed, the rest cannot change a present, so they are not described. The answer is
    the one judging every candidate gives, for confirmed and doubted presents alike."""
    described = [0]
    plain_describe = candidates_stage.describe

    def counting(*args: Any, **kwargs: Any) -> Any:
        described[0] += 1
        return plain_describe(*args, **kwargs)

    monkeypatch.setattr(candidates_stage, "describe", counting)
    fewer = kept = doubted = 0
    for sample in scenes("A", "heldout", 40):
        hand = detect(sample.image)
        if hand.verdict != "present":
            continue
        described[0] = 0
        quick = confirm(sample.image, hand)
        lazily = described[0]
        described[0] = 0
        assert quick == _confirmed_on_every_candidate(sample.image, hand), sample.name
        fewer += lazily < described[0]
        kept += quick.verdict == "present"
        doubted += quick.verdict == "uncertain"
    assert kept >= 10 and doubted >= 1, (kept, doubted)
    assert fewer >= kept * 0.8, (fewer, kept)


def _known(generator: str, split: str, offset: int, kind: str, why: str) -> Any:
    return pytest.param(
        generator,
        split,
        offset,
        kind,
        marks=pytest.mark.xfail(strict=True, reason=why),
        id=f"{generator}:{SPLITS[split] + offset}",
    )


KNOWN_SERVICE_FALSE_PRESENTS = [
    # Generator C's held-out seed 370239 (found by python -m bench.tail_accuracy --offset
    # 70000): a round red logo with white letters "RD" mid-way up a red-brown box car's
    # end wall, 41 px across in an overcast 958x639 scene. The hand-tuned detector scores
    # it 1.00 and every verifier believes it (AB 0.77, A 0.67, B 0.96 above 0.65, 0.57,
    # 0.50); the emblem check (lettering inside the region) holds it since stop 34.
    pytest.param("C", "heldout", 70239, "red_logo", id="C:370239"),
    # Generator A's randomised validation seed 201429 (1 of 706 scenes without a disc on
    # 201000-202399, found while measuring the lettering check): an unlit round tail lamp
    # just above the buffer beam at night, 34 px across in a 1280x720 scene, hand-tuned
    # score 1.00 and every verifier barely above its threshold; no brightness rule told it
    # from a disc at dusk. Its twin at the car's other corner does: the pair check holds it.
    pytest.param("A", "validation", 1429, "tail_lamp", id="A:201429"),
    _known(
        "A",
        "heldout_wide",
        70106,
        "signal_head",
        "known false present of the service on generator A's randomised held-out seed"
        " 370106 (python -m bench.tail_accuracy --generators Aw --offset 70000; 1 of 159 scenes"
        " without a disc): a lit red signal lamp in snow, seen against the car's corner at"
        " buffer-beam height, 35 px across at 1024x768, clipped white core in a red glow."
        " Hand-tuned score 0.96 (the lamp check's glow width does not reach its limit at this"
        " size) and every verifier believes it, though A's were trained on this mode; issue 11"
        " stays open on it",
    ),
    *(
        _known(
            "C",
            "validation",
            offset,
            "tail_lamp",
            f"known false present of the service on generator C's validation seed {seed}"
            " (found in stop 38, on 200000-200299, never looked at before; 2 of 149 scenes"
            " without a disc): a lit red tail lamp, a round lens in a dark square housing at"
            f" the buffer beam's end ({what}). The housing merges with the dark beam below"
            " (and at dusk the glow tints it), so its ring does not end on three sides and the"
            " housing check does not hold it; asking two sides holds neither and 4 true discs"
            " of C's 200000-200299 (stop 38). Hand-tuned score 1.00 and every"
            " verifier above its abstention threshold; issue 11 stays open on it",
        )
        for offset, seed, what in (
            (191, 200191, "overcast, 49 px across at 1817x1080, a salmon-red lens"),
            (200, 200200, "dusk, 85 px across at 1477x1080, a red lens in its glow"),
        )
    ),
]
"""The service's known false ``present``: strict xfails, so that fixing one shows."""


@pytest.mark.parametrize(("generator", "split", "offset", "kind"), KNOWN_SERVICE_FALSE_PRESENTS)
def test_the_service_does_not_call_a_known_hard_negative_a_disc(
    generator: str, split: str, offset: int, kind: str
) -> None:
    sample = _scene(generator, split, offset)
    assert not sample.disc and sample.kind == kind
    assert confirm(sample.image, detect(sample.image)).verdict != "present"
