"""What the holds before the verifiers share: the emblem and housing checks change only a
``present``, never make one, and keep the true discs of the generators.

Measured with them (see :mod:`tail_check.emblem` and :mod:`tail_check.housing` for the
other sets): of the hand-tuned ``present`` on true discs of generator A's reference seeds
340000-340119, neither holds any.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from tail_check import detect
from tail_check.confirm import hold_lookalikes
from tail_check.dataset import scenes
from tail_check.emblem import emblem_reason
from tail_check.housing import housing_reason
from tail_check.lettering import lettering_reason
from tests.tail_check.drawkit import BBox, end_wall, lamp, noisy, roundel
from tests.tail_check.tailkit import hand_presents_on_discs

ROOT = Path(__file__).resolve().parents[2]
Reason = Callable[[NDArray[np.uint8], BBox], "str | None"]


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


def _roundel_scene() -> NDArray[np.uint8]:
    image = end_wall()
    roundel(image, (600, 390), 20, "RD")
    return noisy(image)


def _lamp_scene() -> NDArray[np.uint8]:
    image = end_wall()
    lamp(image, (600, 400), 22, "ring")
    return noisy(image)


@pytest.mark.parametrize("scene", [_roundel_scene, _lamp_scene], ids=["roundel", "lamp"])
def test_only_a_present_is_held_and_nothing_becomes_present(
    scene: Callable[[], NDArray[np.uint8]],
) -> None:
    image = scene()
    hand = detect(image)
    assert hand.verdict == "present"
    assert hold_lookalikes(image, hand).verdict == "uncertain"
    for verdict in ("absent", "uncertain"):
        given = replace(hand, verdict=verdict)
        assert hold_lookalikes(image, given) is given


MEASURED_DISCS_HELD = {"emblem": 0, "housing": 0}


def test_true_discs_are_not_taken_for_roundels_or_lamps() -> None:
    checks: dict[str, Reason] = {"emblem": emblem_reason, "housing": housing_reason}
    held = dict.fromkeys(checks, 0)
    total = 0
    for sample, hand in hand_presents_on_discs(scenes("A", "heldout", 120, offset=40000)):
        total += 1
        x, y, w, h = (int(v) for v in hand.bbox or (0, 0, 0, 0))
        for name, reason in checks.items():
            held[name] += reason(sample.image, (x, y, w, h)) is not None
    assert total >= 50
    assert held == MEASURED_DISCS_HELD, (held, total)


# Boxes a caller may hand the holds: beyond each edge of the 800x600 scene, straddling a
# corner, a single pixel, and one so tall that the working scale shrinks it to nothing.
_OUTSIDE = [
    (600, -90, 40, 40),
    (580, -45, 40, 40),
    (-90, 380, 40, 40),
    (-220, 370, 40, 40),
    (900, 380, 40, 40),
    (600, 700, 40, 40),
]
_ODD = [
    (-20, -20, 40, 40),
    (790, 590, 40, 40),
    (600, 390, 1, 1),
    (600, 0, 1, 600),
    (600, 590, 40, 20000),
    (-5000, -5000, 20000, 20000),
]


@pytest.mark.parametrize("box", _OUTSIDE + _ODD, ids=str)
@pytest.mark.parametrize("scene", [_roundel_scene, _lamp_scene], ids=["roundel", "lamp"])
def test_a_box_beyond_the_image_is_judged_on_its_own_pixels_only(
    scene: Callable[[], NDArray[np.uint8]], box: BBox
) -> None:
    """A box wholly outside the image has no pixels to hold it by (a negative slice end
    once wrapped round to the far edge, and found the roundel there); none raises."""
    image = scene()
    before = image.copy()
    reasons = [check(image, box) for check in (emblem_reason, housing_reason, lettering_reason)]
    np.testing.assert_array_equal(image, before)
    if box in _OUTSIDE:
        assert reasons == [None, None, None]
