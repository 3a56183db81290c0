"""Two-camera comparison and calibration."""

from __future__ import annotations

import numpy as np
import pytest

from tail_check import DEFAULT_PROFILE, calibrate, compare, compare_with_departure, detect
from tail_check.synth import render_snapshot


def _snap(seed: int, disc: bool, condition: str = "day") -> np.ndarray:
    image, _ = render_snapshot(
        seed,
        disc=disc,
        condition=condition,
        car_colour="grey",
        distractors=(),
        occlusion=0.0,
        jpeg_quality=90,
    )
    return image


def test_disc_at_departure_and_arrival_is_present_and_similar() -> None:
    result = compare(_snap(10, True), _snap(11, True))
    assert result.verdict == "present" and not result.lost_rear
    assert result.similarity is not None and result.similarity > 0.35
    assert result.to_dict()["departure"]["verdict"] == "present"


def test_disc_lost_between_departure_and_arrival_is_flagged() -> None:
    result = compare(_snap(12, True), _snap(13, False))
    assert result.verdict == "absent" and result.lost_rear
    assert "lost" in result.reasons[0]


def test_no_departure_disc_means_arrival_judged_alone() -> None:
    result = compare(_snap(14, False), _snap(15, True))
    assert result.departure.verdict == "absent"
    assert result.verdict == detect(_snap(15, True)).verdict == "present"
    assert not result.lost_rear and result.similarity is None


def test_compare_with_departure_result_reuses_the_detection() -> None:
    dep = _snap(16, True)
    first = detect(dep)
    result = compare_with_departure(first, dep, _snap(17, True))
    assert result.departure is first and result.verdict == "present"


def test_calibrate_from_a_clicked_point() -> None:
    image, label = render_snapshot(
        20,
        disc=True,
        condition="dusk",
        car_colour="green",
        distractors=(),
        occlusion=0.0,
        jpeg_quality=90,
    )
    assert label.reference_point is not None and label.bbox is not None
    profile = calibrate(image, label.reference_point, name="cam-7")
    h, w = image.shape[:2]
    x0, y0, x1, y1 = profile.search_region
    bx, by, bw, bh = label.bbox
    assert x0 * w <= bx and bx + bw <= x1 * w and y0 * h <= by and by + bh <= y1 * h
    r, g, b = profile.reference_rgb
    assert r > 2.5 * g and r > 2.5 * b  # the disc's own (dusk-dimmed) red
    assert profile.name == "cam-7" and profile.c_delta == DEFAULT_PROFILE.c_delta
    dmin, dmax = profile.disc_diameter_range
    assert dmin < dmax < 3 * dmin
    assert detect(image, profile).verdict == "present"


def test_calibrate_refuses_bad_points() -> None:
    image, label = render_snapshot(
        21, disc=True, condition="day", car_colour="grey", distractors=(), occlusion=0.0
    )
    with pytest.raises(ValueError, match="outside"):
        calibrate(image, (5000, 10))
    with pytest.raises(ValueError, match="disc"):
        calibrate(image, (5, 5))  # sky, not a disc
