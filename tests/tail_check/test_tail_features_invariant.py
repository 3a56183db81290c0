"""The verifier's features: names match the vector, colour survives a colour cast, a
lamp's light is told from paint, and the beam under a disc is seen (issue 11)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tail_check import synth
from tail_check.dataset import scenes
from tail_check.pipeline import FEATURE_NAMES, PIPELINE_PROFILE, find_candidates
from tail_check.pipeline.proposals import make_maps
from tail_check.synth_wide import random_wide_snapshot


def _scene(red_gain: float = 1.0, lamp: bool = False) -> np.ndarray:
    """A grey car end with a dark buffer beam and a red disc (or a lit lamp) above it."""
    img = np.full((480, 640, 3), (120, 125, 125), np.uint8)
    cv2.rectangle(img, (100, 80), (540, 330), (110, 112, 110), -1)
    cv2.rectangle(img, (100, 330), (540, 380), (25, 25, 25), -1)
    colour = (60, 60, 255) if lamp else (40, 40, 190)
    cv2.circle(img, (440, 290), 22, colour, -1, cv2.LINE_AA)
    if lamp:
        cv2.circle(img, (440, 290), 14, (235, 235, 255), -1, cv2.LINE_AA)
    out = img.astype(np.float32) * np.asarray([1.0, 1.0, red_gain], np.float32)
    return np.asarray(np.clip(out, 0, 255), np.uint8)


def _disc_features(image: np.ndarray) -> dict[str, float]:
    cands, _ = find_candidates(image, PIPELINE_PROFILE)
    near = [c for c in cands if abs(c.bbox[0] + c.bbox[2] / 2 - 440) < 10 and c.bbox[2] > 30]
    assert near, [c.bbox for c in cands]
    return dict(zip(FEATURE_NAMES, near[0].features.tolist(), strict=True))


def test_feature_names_match_the_vector() -> None:
    image = _scene()
    maps = make_maps(image, PIPELINE_PROFILE)
    cands, _ = find_candidates(image, PIPELINE_PROFILE)
    assert cands
    for c in cands:
        f = dict(zip(FEATURE_NAMES, c.features.tolist(), strict=True))
        assert f["scene_bright"] == pytest.approx(maps.bright)
        assert f["source"] in {0.0, 1.0, 2.0, 3.0, 4.0, 9.0}
        assert 0.0 <= f["in_redness"] <= 1.0 and 0.0 <= f["in_clipped"] <= 1.0
    assert "in_band_share" not in FEATURE_NAMES  # one generator's paint, memorised


def test_white_balanced_redness_survives_a_colour_cast() -> None:
    plain, cast = _disc_features(_scene()), _disc_features(_scene(red_gain=1.3))
    assert abs(cast["in_redness_wb"] - plain["in_redness_wb"]) < 0.5 * abs(
        cast["in_redness"] - plain["in_redness"]
    )
    assert plain["redness_wb_contrast"] > 0.3


def test_a_lit_lamp_clips_and_paint_does_not() -> None:
    assert _disc_features(_scene(lamp=True))["in_clipped"] > 0.2
    assert _disc_features(_scene())["in_clipped"] == 0.0


def test_the_beam_under_a_disc_is_darker_than_its_surroundings() -> None:
    f = _disc_features(_scene())
    assert f["below_contrast"] > 0.2 and f["above_below"] > 0.2


def test_generator_a_trains_on_randomised_scenes_and_reports_on_reference_ones() -> None:
    held = next(scenes("A", "heldout", 1))
    rng = np.random.default_rng(300_000)
    size = ((640, 480), (800, 600), (1024, 768), (1280, 720))[int(rng.integers(4))]
    assert np.array_equal(held.image, synth.random_snapshot(rng, size=size)[0])
    train = next(scenes("A", "train", 1))
    rng = np.random.default_rng(100_000)
    size = ((640, 480), (800, 600), (1024, 768), (1280, 720))[int(rng.integers(4))]
    assert np.array_equal(train.image, random_wide_snapshot(rng, size=size)[0])
    wide = next(scenes("A", "heldout_wide", 1))
    assert wide.image.shape != held.image.shape or not np.array_equal(wide.image, held.image)
