"""A red roundel with lettering inside is held ``uncertain``; a disc with its reflector is not.

The roundels are drawn here (a railway's initials, a digit, an arrow in white on a red
circle); the discs are the generators' and drawn ones with a reflector at the centre,
brighter red by day or near white when lit.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from tail_check.emblem import EmblemParams, emblem_marks, emblem_reason
from tests.tail_check.drawkit import (
    WHITE,
    arrow_roundel,
    end_wall,
    noisy,
    roundel,
    tail_disc,
)
from tests.tail_check.tailkit import assert_service_holds

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", autouse=True)
def _cache() -> None:
    os.environ.setdefault("DEPOT_TAIL_CACHE", str(ROOT / "var" / "tail_cache"))


def test_a_roundel_every_verifier_believes_is_held_uncertain() -> None:
    # A railway's initials on a small roundel just above the buffer beam: before this
    # check the service said ``present`` (disc score 1.00, every verifier above its
    # threshold).
    image = end_wall()
    roundel(image, (600, 390), 20, "RD")
    assert_service_holds(noisy(image), "inside the disc-shaped region")


@pytest.mark.parametrize("text", ["RD", "M", "5", "XK", "arrow"])
@pytest.mark.parametrize("r", [20, 36, 70])
def test_lettering_inside_a_roundel_is_found(text: str, r: int) -> None:
    image = end_wall()
    centre = (400, 250)
    box = arrow_roundel(image, centre, r) if text == "arrow" else roundel(image, centre, r, text)
    image = noisy(image)
    assert emblem_reason(image, box) is not None


@pytest.mark.parametrize("text", ["5", "R", "P", "W", "M", "3"])
@pytest.mark.parametrize("r", [20, 36, 60])
def test_bold_lettering_inside_a_roundel_is_found(text: str, r: int) -> None:
    # Bold strokes fill their convex hull about as well as a small reflector does
    # (0.72-0.91); their outline is no ellipse (the independent trial's bold 5, R, P, W).
    image = end_wall()
    box = roundel(image, (400, 250), r, text, bold=True)
    assert emblem_reason(noisy(image), box) is not None


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
    box = roundel(image, (400, 250), 36, "RD")
    assert emblem_marks(image, box, params=EmblemParams(min_side_px=73)) == []
    assert emblem_reason(image, (-40, -40, 30, 30)) is None  # outside the image
