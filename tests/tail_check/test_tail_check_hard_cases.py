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

HARD_COLOURS = ("red", "red_brown", "rust", "orange", "brown", "grey")
HARD_COUNT = 36


def _disc_mask(cut_at: float | None) -> np.ndarray:
    mask = np.zeros((80, 80), np.uint8)
    cv2.ellipse(mask, (40, 40), (20, 23), 5, 0, 360, 1, -1)
    if cut_at is not None:
        mask[:, int(20 + 40 * (1 - cut_at)) :] = 0
    ys, xs = np.nonzero(mask)
    return mask[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1].astype(bool)


def test_whole_disc_needs_no_cut_fit() -> None:
    shape = measure_region(_disc_mask(None))
    assert shape is not None
    assert disc_score(shape, 0.08, 0.0, DEFAULT_PROFILE) >= DEFAULT_PROFILE.present_threshold


@pytest.mark.parametrize("hidden", [0.1, 0.2, 0.3])
def test_disc_cut_by_a_straight_edge_is_fitted_as_a_whole_ellipse(hidden: float) -> None:
    shape = measure_region(_disc_mask(1 - hidden))
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


def test_hand_wheels_and_red_objects_on_red_cars_are_never_present() -> None:
    verdicts = []
    for i in range(HARD_COUNT):
        rng = np.random.default_rng([99, i])
        others = [d for d in DISTRACTORS if d != "hand_wheel"]
        extra = tuple(str(d) for d in rng.choice(others, int(rng.integers(0, 3)), replace=False))
        image, _ = render_snapshot(
            rng,
            disc=False,
            condition=CONDITIONS[i % len(CONDITIONS)],
            car_colour=HARD_COLOURS[i % len(HARD_COLOURS)],
            distractors=("hand_wheel", *extra),
        )
        verdicts.append(detect(image).verdict)
    assert "present" not in verdicts, verdicts
