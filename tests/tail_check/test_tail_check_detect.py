"""Detector behaviour on generated and real snapshots."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tail_check import DEFAULT_PROFILE, decode_snapshot, detect
from tail_check.dataset import real_dir
from tail_check.synth import render_snapshot

REAL = real_dir() / "red_wagons"
"""Found wherever the checkout is (a worktree too): ``DEPOT_REAL_DATA_DIR`` or the default."""


def _iou(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> float:
    ax, ay, aw, ah = a
    bx, by, bw, bh = b
    iw = max(0, min(ax + aw, bx + bw) - max(ax, bx))
    ih = max(0, min(ay + ah, by + bh) - max(ay, by))
    inter = iw * ih
    return inter / (aw * ah + bw * bh - inter)


def test_day_disc_is_present_with_its_box_and_fraction() -> None:
    image, label = render_snapshot(
        1,
        disc=True,
        condition="day",
        car_colour="green",
        distractors=(),
        occlusion=0.0,
        jpeg_quality=90,
    )
    before = image.copy()
    result = detect(image)
    assert np.array_equal(image, before)  # input untouched
    assert result.verdict == "present" and result.score >= DEFAULT_PROFILE.present_threshold
    assert label.bbox is not None and result.bbox is not None
    assert _iou(result.bbox, label.bbox) > 0.7
    # ŝ in the search region is the disc itself here (the reflector may be left out)
    assert result.pixel_fraction == pytest.approx(label.disc_fraction, rel=0.35)


def test_no_disc_is_absent_with_high_confidence() -> None:
    image, _ = render_snapshot(
        2, disc=False, condition="day", car_colour="grey", distractors=(), occlusion=0.0
    )
    result = detect(image)
    assert result.verdict == "absent"
    assert result.bbox is None
    assert result.score > DEFAULT_PROFILE.absent_confidence


def test_red_plate_where_the_disc_would_be_is_not_a_disc() -> None:
    for seed in range(6):
        image, _ = render_snapshot(
            seed,
            disc=False,
            condition="day",
            car_colour="red_brown",
            distractors=("red_plate", "red_logo"),
        )
        assert detect(image).verdict != "present"


def test_night_disc_with_lit_reflector_is_found() -> None:
    image, _ = render_snapshot(
        5, disc=True, condition="night", car_colour="grey", distractors=(), occlusion=0.0
    )
    assert detect(image).verdict == "present"


def test_result_does_not_depend_on_image_size() -> None:
    image, label = render_snapshot(
        3,
        disc=True,
        condition="day",
        size=(640, 480),
        car_colour="blue",
        distractors=(),
        occlusion=0.0,
    )
    small = detect(cv2.resize(image, (320, 240), interpolation=cv2.INTER_AREA))
    large = detect(cv2.resize(image, (1280, 960), interpolation=cv2.INTER_LINEAR))
    base = detect(image)
    assert small.verdict == base.verdict == large.verdict == "present"
    assert small.bbox is not None and large.bbox is not None and base.bbox is not None
    scaled_small = tuple(2 * v for v in small.bbox)
    scaled_large = tuple(v // 2 for v in large.bbox)
    assert _iou(scaled_small, base.bbox) > 0.7 and _iou(scaled_large, base.bbox) > 0.7
    assert small.pixel_fraction == pytest.approx(large.pixel_fraction, rel=0.15)


def test_to_dict_has_the_public_fields() -> None:
    image, _ = render_snapshot(4, disc=True, condition="dusk")
    d = detect(image).to_dict()
    assert {"verdict", "score", "bbox", "pixel_fraction"} <= set(d)


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((10, 10, 3), np.uint8),
        np.zeros((100, 100), np.uint8),
        np.zeros((50, 50, 4), np.uint8),
        "image.jpg",
        np.full((40, 40, 3), np.nan),
    ],
)
def test_bad_images_raise_value_error(bad: object) -> None:
    with pytest.raises(ValueError, match="image"):
        detect(bad)  # type: ignore[arg-type]


def test_float_images_are_accepted() -> None:
    image, _ = render_snapshot(6, disc=True, condition="day", distractors=(), occlusion=0.0)
    assert detect(image.astype(np.float64)).verdict == detect(image).verdict


def test_decode_snapshot_and_reduced_decode() -> None:
    image, _ = render_snapshot(7, disc=True, condition="day", size=(640, 480))
    ok, buf = cv2.imencode(".jpg", image)
    assert ok
    full = decode_snapshot(buf.tobytes())
    half = decode_snapshot(buf.tobytes(), reduce=2)
    assert full.shape == (480, 640, 3) and half.shape == (240, 320, 3)
    with pytest.raises(ValueError, match="decodable"):
        decode_snapshot(b"not an image")
    with pytest.raises(ValueError, match="reduce"):
        decode_snapshot(buf.tobytes(), reduce=3)


@pytest.mark.skipif(not REAL.is_dir(), reason=f"real red-wagon photos not found at {REAL}")
def test_real_red_wagon_photos_never_yield_present() -> None:
    files = sorted(REAL.glob("*.jpg"))
    assert len(files) >= 10
    for path in files:
        image = cv2.imread(str(path))
        result = detect(image)
        assert result.verdict in ("absent", "uncertain"), (path.name, result.to_dict())
