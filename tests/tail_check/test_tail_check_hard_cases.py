"""Hard cases of the detector: partly hidden discs, hand wheels and red objects on
red-brown and rust cars (no disc), and the cut-disc shape fit itself."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tail_check import DEFAULT_PROFILE, detect
from tail_check.regions import disc_score
from tail_check.shape import measure_region
from tail_check.synth import CONDITIONS, DISTRACTORS, render_snapshot

HARD_COLOURS = ("red", "red_brown", "rust", "orange")
HARD_COUNT = 60


def _disc_mask(hidden: float) -> np.ndarray:
    """A slightly squashed, tilted disc with the right ``hidden`` share of its width cut off."""
    mask = np.zeros((80, 80), np.uint8)
    cv2.ellipse(mask, (40, 40), (20, 23), 5, 0, 360, 1, -1)
    if hidden > 0:
        mask[:, int(round(60 - 40 * hidden)) :] = 0
    ys, xs = np.nonzero(mask)
    return mask[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1].astype(bool)


def test_whole_disc_needs_no_cut_fit() -> None:
    shape = measure_region(_disc_mask(0.0))
    assert shape is not None
    assert disc_score(shape, 0.08, 0.0, DEFAULT_PROFILE) >= DEFAULT_PROFILE.present_threshold


@pytest.mark.parametrize("hidden", [0.1, 0.2, 0.3])
def test_disc_cut_by_a_straight_edge_is_fitted_as_a_whole_ellipse(hidden: float) -> None:
    shape = measure_region(_disc_mask(hidden))
    assert shape is not None and shape.cut is not None
    assert shape.cut.iou > 0.92
    assert shape.cut.diameter == pytest.approx(2 * np.sqrt(20 * 23), rel=0.08)
    assert shape.cut.aspect == pytest.approx(23 / 20, abs=0.08)
    assert shape.cut.visible < 1 - 0.5 * hidden


def test_boxes_and_rounded_boxes_are_no_cut_discs() -> None:
    box = np.ones((30, 50), bool)
    shape = measure_region(box)
    assert shape is not None
    assert disc_score(shape, 0.08, 0.0, DEFAULT_PROFILE) < DEFAULT_PROFILE.uncertain_threshold
    rounded = np.zeros((40, 60), np.uint8)
    cv2.rectangle(rounded, (8, 0), (51, 39), 1, -1)
    cv2.circle(rounded, (8, 20), 8, 1, -1)
    shape = measure_region(rounded.astype(bool))
    assert shape is not None
    assert disc_score(shape, 0.08, 0.0, DEFAULT_PROFILE) < DEFAULT_PROFILE.present_threshold


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_disc_partly_behind_a_pole_is_present(seed: int) -> None:
    image, label = render_snapshot(
        seed, disc=True, condition="day", car_colour="grey", distractors=(), occlusion=0.15
    )
    assert label.occluded > 0.05
    assert detect(image).verdict == "present"


def test_red_objects_on_red_and_brown_cars_are_never_present() -> None:
    """The hard-negative set: no disc, cars of the disc's colour family, up to two red
    non-disc objects (hand wheels, plates, logos, lamps, stripes, squares)."""
    verdicts = []
    for i in range(HARD_COUNT):
        rng = np.random.default_rng([99, i])
        colour = HARD_COLOURS[i % len(HARD_COLOURS)]
        objects = tuple(str(d) for d in rng.choice(DISTRACTORS, int(rng.integers(0, 3)), False))
        image, _ = render_snapshot(
            rng,
            disc=False,
            condition=CONDITIONS[i % len(CONDITIONS)],
            car_colour=colour,
            size=(480, 360),
            distractors=objects,
        )
        verdicts.append(detect(image).verdict)
    assert "present" not in verdicts, verdicts
