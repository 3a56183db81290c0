"""Table look-ups that replace per-pixel arithmetic give the very same pixels.

The speed work of issue #11 part 4 replaces the veil subtraction by a 256-level table and
the colour band by integer rank tables; both must be exact rewrites (the detector's
answers are compared bit for bit by ``bench.tail_answers``), on any image and any band.
"""

from __future__ import annotations

import importlib

import cv2
import numpy as np

from tail_check.colour import TABLE_MIN_PIXELS, _rank_tables, band_mask

RNG = np.random.default_rng(41)
detect_module = importlib.import_module("tail_check.detect")


def test_veil_subtraction_by_table_is_opencvs_subtraction() -> None:
    for i in range(300):
        level = float(RNG.uniform(0, 300)) if i % 3 else float(RNG.integers(0, 256)) + 0.5
        h, w = (int(v) for v in RNG.integers(1, 300, 2))
        image = RNG.integers(0, 256, (h, w, 3), dtype=np.uint8)
        plain = cv2.subtract(image, np.full(3, level, np.float64))
        assert np.array_equal(detect_module._subtract(image, level), plain), level
    image = RNG.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    assert detect_module._subtract(image, 0.0) is image


def test_rank_tables_give_the_float_band_in_both_widths() -> None:
    """Narrow bands of a few hundred gain bounds fit uint8 ranks, wide ones need uint16:
    both give the float path's mask."""
    noise = RNG.integers(0, 256, (160, 160, 3), dtype=np.uint8)
    image = np.asarray(cv2.GaussianBlur(noise, (0, 0), 1.0), np.uint8)
    assert image.shape[0] * image.shape[1] >= TABLE_MIN_PIXELS
    widths = set()
    for _ in range(120):
        ref = tuple(float(v) for v in RNG.uniform(0, 255, 3))
        c_delta = float(RNG.choice([0.05, 0.1, 0.25, 0.5, 1.0, 2.0]))
        k = float(RNG.uniform(0.05, 2.0))
        gains = (k, k * float(RNG.choice([1.0, 1.3, 4.0, 20.0])))
        ref_bgr = np.array(ref[::-1], dtype=np.float32)
        half = np.float32(c_delta * float(np.mean(ref_bgr)))
        key = (float(ref_bgr[0]), float(ref_bgr[1]), float(ref_bgr[2]))
        widths.add(_rank_tables(key, float(half), *gains)[0][0].dtype)
        fast = band_mask(image, ref, c_delta, gain_range=gains)  # type: ignore[arg-type]
        plain = band_mask(image.astype(np.float32), ref, c_delta, gain_range=gains)  # type: ignore[arg-type]
        assert fast.dtype == np.bool_ and np.array_equal(fast, plain), (ref, c_delta, gains)
    assert widths == {np.dtype(np.uint8), np.dtype(np.uint16)}
