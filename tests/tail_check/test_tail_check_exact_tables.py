"""Table look-ups that replace per-pixel arithmetic give the very same pixels.

The speed work of issue #11 part 4 replaces the veil subtraction by a 256-level table and
the colour band by integer rank tables; both must be exact rewrites (the detector's
answers are compared bit for bit by ``bench.tail_answers``), on any image and any band.
"""

from __future__ import annotations

import importlib
import math

import cv2
import numpy as np

from tail_check import DEFAULT_PROFILE
from tail_check.colour import TABLE_MIN_PIXELS, _rank_tables, band_mask, surround_share
from tail_check.detect import WORK_SIDE
from tail_check.pixels import subtract_level
from tail_check.regions import MAX_CANDIDATES

RNG = np.random.default_rng(41)
regions = importlib.import_module("tail_check.regions")


def test_veil_subtraction_by_table_is_opencvs_subtraction() -> None:
    for i in range(300):
        level = float(RNG.uniform(0, 300)) if i % 3 else float(RNG.integers(0, 256)) + 0.5
        h, w = (int(v) for v in RNG.integers(1, 300, 2))
        image = RNG.integers(0, 256, (h, w, 3), dtype=np.uint8)
        plain = cv2.subtract(image, np.full(3, level, np.float64))
        assert np.array_equal(subtract_level(image, level), plain), level
    image = RNG.integers(0, 256, (20, 30, 3), dtype=np.uint8)
    assert subtract_level(image, 0.0) is image


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


def _seeds_of_the_whole_mask(mask: np.ndarray, area_min: float, area_max: float) -> list:
    """The seeds as labelled before: the whole working image, OpenCV's statistics."""
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    mask_u8 = mask.view(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStatsWithAlgorithm(
        np.asarray(cv2.erode(mask_u8, cross), np.uint8), 8, cv2.CV_16U, cv2.CCL_GRANA
    )
    areas = stats[:, cv2.CC_STAT_AREA].astype(np.int64)
    keep = np.nonzero((areas[1:] >= area_min) & (areas[1:] <= area_max))[0] + 1
    keep = keep[np.argsort(-areas[keep])][:MAX_CANDIDATES]
    out = []
    for label in keep:
        x, y, w, h = (int(v) for v in stats[label, :4])
        x, y = max(0, x - 1), max(0, y - 1)
        w, h = min(mask.shape[1] - x, w + 2), min(mask.shape[0] - y, h + 2)
        core = (labels[y : y + h, x : x + w] == label).view(np.uint8)
        region = cv2.dilate(core, cross) & mask_u8[y : y + h, x : x + w]
        out.append(((x, y, w, h), region.astype(bool)))
    return out


def test_seeds_labelled_on_the_occupied_part_are_the_whole_masks() -> None:
    p = DEFAULT_PROFILE
    dmin, dmax = p.disc_diameter_range
    area_min = math.pi / 4 * (0.5 * dmin * WORK_SIDE) ** 2
    area_max = math.pi / 4 * (1.3 * dmax * WORK_SIDE) ** 2
    found = 0
    for i in range(150):
        h, w = (int(v) for v in RNG.integers(30, 260, 2))
        noise = cv2.GaussianBlur(RNG.random((h, w)).astype(np.float32), (0, 0), 3.0)
        mask = noise > float(np.quantile(noise, RNG.uniform(0.6, 0.97)))
        if i % 3 == 0:  # occupied part off the corner, at odd and even offsets
            mask[: int(RNG.integers(0, h // 2)), :] = False
            mask[:, : int(RNG.integers(0, w // 2))] = False
        if i % 5 == 0:  # regions on the image border
            mask[:, -3:] = True
        if i % 7 == 0:  # a region on the left and top border, alone or the widest
            mask[: int(RNG.integers(0, h)), int(RNG.integers(0, w)) :] = False
            mask[:12, : int(RNG.integers(12, w))] = True
            mask[: int(RNG.integers(12, h)), :12] = True
        got = regions._seeds(mask, p, WORK_SIDE)
        want = _seeds_of_the_whole_mask(mask, area_min, area_max)
        assert [b for b, _ in got] == [b for b, _ in want]
        assert all(np.array_equal(g, r) for (_, g), (_, r) in zip(got, want, strict=True))
        found += len(got)
    assert found > 50


def test_surround_with_a_window_band_is_the_or_ed_band() -> None:
    for _ in range(300):
        h, w = (int(v) for v in RNG.integers(20, 120, 2))
        band = RNG.random((h, w)) > 0.6
        red = RNG.integers(0, 256, (h, w), dtype=np.uint8)
        lh, lw = (int(v) for v in RNG.integers(1, 60, 2))
        ex, ey = int(RNG.integers(0, w)), int(RNG.integers(0, h))
        local = RNG.random((min(lh, h - ey), min(lw, w - ex))) > 0.3
        placed = np.zeros_like(band)
        placed[ey : ey + local.shape[0], ex : ex + local.shape[1]] = local
        bw, bh = int(RNG.integers(1, 40)), int(RNG.integers(1, 40))
        box = (int(RNG.integers(-5, w)), int(RNG.integers(-5, h)), bw, bh)
        level = float(RNG.uniform(10, 250))
        plain = surround_share(band | placed, red, box, level)
        assert surround_share(band, red, box, level, extra=(local, (ex, ey))) == plain


def test_masked_mean_is_numpys_mean_of_the_masked_pixels() -> None:
    for _ in range(500):
        h, w = (int(v) for v in RNG.integers(1, 90, 2))
        image = RNG.integers(0, 256, (h, w, 3), dtype=np.uint8)
        mask = RNG.random((h, w)) > RNG.uniform(0, 0.99)
        mask.flat[int(RNG.integers(0, h * w))] = True
        got = regions.masked_mean(image[:, :], mask)
        assert np.array_equal(got, image[mask].mean(axis=0))
        assert got.dtype == np.float64
