"""A red roundel with lettering inside is held ``uncertain``; a disc with its reflector is not.

The roundels are drawn here (a railway's initials, a digit, an arrow in white on a red
circle); the discs are the generators' and drawn ones with a reflector at the centre,
brighter red by day or near white when lit.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

from tail_check import confirm, detect
from tail_check.confirm import hold_lettering
from tail_check.dataset import scenes
from tail_check.emblem import EmblemParams, emblem_marks, emblem_reason
from tests.tail_check.drawkit import SIGNAL_RED, WHITE, BBox, end_wall, noisy, tail_disc
from tests.tail_check.tailkit import hand_presents_on_discs

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


def _roundel(image: NDArray[np.uint8], centre: tuple[int, int], r: int, text: str) -> BBox:
    cv2.circle(image, centre, r, SIGNAL_RED, -1, cv2.LINE_AA)
    scale = r / 28.0
    (tw, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, max(2, r // 9))
    origin = (centre[0] - tw // 2, centre[1] + th // 2)
    cv2.putText(
        image, text, origin, cv2.FONT_HERSHEY_SIMPLEX, scale, WHITE, max(2, r // 9), cv2.LINE_AA
    )
    return centre[0] - r, centre[1] - r, 2 * r, 2 * r


def _arrow_roundel(image: NDArray[np.uint8], centre: tuple[int, int], r: int) -> BBox:
    cv2.circle(image, centre, r, SIGNAL_RED, -1, cv2.LINE_AA)
    cx, cy = centre
    tip, tail = (cx + r * 6 // 10, cy), (cx - r * 6 // 10, cy)
    cv2.arrowedLine(image, tail, tip, WHITE, max(2, r // 7), cv2.LINE_AA, tipLength=0.4)
    return cx - r, cy - r, 2 * r, 2 * r


def test_a_roundel_every_verifier_believes_is_held_uncertain() -> None:
    # A railway's initials on a small roundel just above the buffer beam: before this
    # check the service said ``present`` (disc score 1.00, every verifier above its
    # threshold).
    image = end_wall()
    _roundel(image, (600, 390), 20, "RD")
    image = noisy(image)
    before = image.copy()
    hand = detect(image)
    assert hand.verdict == "present"  # the error the check exists for
    checked = confirm(image, hand)
    assert checked.verdict == "uncertain"
    assert "inside the disc-shaped region" in checked.reasons[0]
    assert checked.reasons[1:] == hand.reasons and checked.bbox == hand.bbox
    np.testing.assert_array_equal(image, before)  # the input is never modified


@pytest.mark.parametrize("text", ["RD", "M", "5", "XK", "arrow"])
@pytest.mark.parametrize("r", [20, 36, 70])
def test_lettering_inside_a_roundel_is_found(text: str, r: int) -> None:
    image = end_wall()
    centre = (400, 250)
    box = _arrow_roundel(image, centre, r) if text == "arrow" else _roundel(image, centre, r, text)
    image = noisy(image)
    assert emblem_reason(image, box) is not None


@pytest.mark.parametrize(
    "reflector", [(60, 60, 255), (200, 215, 250), (245, 245, 245)], ids=["day", "lit", "white"]
)
@pytest.mark.parametrize("r", [14, 30, 60])
def test_a_disc_with_its_reflector_at_the_centre_is_not_held(
    reflector: tuple[int, int, int], r: int
) -> None:
    image = end_wall()
    box = tail_disc(image, (600, 440 - r - 12), r, reflector)
    image = noisy(image)
    assert emblem_reason(image, box) is None
    marks = emblem_marks(image, box)
    assert len(marks) <= 1


def test_a_disc_under_snowflakes_is_not_held() -> None:
    image = end_wall()
    box = tail_disc(image, (600, 380), 40, (60, 60, 255))
    rng = np.random.default_rng(3)
    for _ in range(400):
        x, y = int(rng.integers(0, 800)), int(rng.integers(0, 600))
        cv2.circle(image, (x, y), int(rng.integers(1, 3)), WHITE, -1, cv2.LINE_AA)
    image = noisy(image)
    assert emblem_reason(image, box) is None


def test_boxes_too_small_to_read_are_not_judged() -> None:
    image = end_wall()
    box = _roundel(image, (400, 250), 36, "RD")
    assert emblem_marks(image, box, params=EmblemParams(min_side_px=73)) == []
    assert emblem_reason(image, (-40, -40, 30, 30)) is None  # outside the image


def test_only_a_present_is_held_and_nothing_becomes_present() -> None:
    image = end_wall()
    _roundel(image, (400, 250), 36, "RD")
    image = noisy(image)
    hand = detect(image)
    for verdict in ("absent", "uncertain"):
        given = replace(hand, verdict=verdict)
        assert hold_lettering(image, given) is given


MEASURED_DISCS_HELD = 0
"""Of the hand-tuned ``present`` on true discs of generator A's reference seeds
340000-340119, how many the emblem check held ``uncertain`` (with the other sets measured
in the module's docstring)."""


def test_true_discs_are_not_taken_for_roundels() -> None:
    held = total = 0
    for sample, hand in hand_presents_on_discs(scenes("A", "heldout", 120, offset=40000)):
        total += 1
        x, y, w, h = (int(v) for v in hand.bbox or (0, 0, 0, 0))
        held += emblem_reason(sample.image, (x, y, w, h)) is not None
    assert total >= 50
    assert held == MEASURED_DISCS_HELD, (held, total)
