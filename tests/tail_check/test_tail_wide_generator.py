"""Generator A's domain randomisation covers the scene kinds issue 11 lists as failures,
and the verifier's colour features do not depend on the camera's white balance."""

from __future__ import annotations

import colorsys

import numpy as np
import pytest

from tail_check.dataset import scenes
from tail_check.pipeline import FEATURE_NAMES, PIPELINE_PROFILE, find_candidates
from tail_check.synth import render_snapshot
from tail_check.synth_wide import WIDE_DISTRACTORS, random_wide_snapshot

N = 80


@pytest.fixture(scope="module")
def wide() -> list[tuple[np.ndarray, object]]:
    return [random_wide_snapshot(np.random.default_rng([7, i])) for i in range(N)]


def _hsv_of_box(image: np.ndarray, box: tuple[int, int, int, int]) -> tuple[float, float, float]:
    x, y, w, h = box
    patch = image[y + h // 4 : y + 3 * h // 4 + 1, x + w // 4 : x + 3 * w // 4 + 1]
    b, g, r = (float(np.median(patch[..., k])) / 255 for k in range(3))
    return colorsys.rgb_to_hsv(r, g, b)


def test_wide_scenes_hold_the_issues_kinds(wide: list[tuple[np.ndarray, object]]) -> None:
    labels = [lab for _, lab in wide]
    discs = [lab for lab in labels if lab.disc]  # type: ignore[attr-defined]
    assert 0.3 < len(discs) / N < 0.7
    boxes = [lab.bbox for lab in discs]  # type: ignore[attr-defined]
    assert all(b is not None for b in boxes)
    heights = [img.shape[0] for img, lab in wide if lab.disc]  # type: ignore[attr-defined]
    # edge-on: the visible disc at least 1.6 times as tall as wide
    assert any(b[3] >= 1.6 * b[2] for b in boxes)
    # small: radius about 2 % of the image height or less
    assert any(b[3] / 2 <= 0.02 * h for b, h in zip(boxes, heights, strict=True))
    kinds = {k for lab in labels for k in lab.distractors}  # type: ignore[attr-defined]
    assert {"red_lettering", "red_barrier"} <= kinds <= set(WIDE_DISTRACTORS)
    assert {lab.car_colour for lab in labels} == {"wide_red", "wide_other"}  # type: ignore[attr-defined]
    assert any(lab.condition == "night" for lab in discs)  # type: ignore[attr-defined]


def test_wide_discs_range_from_faded_pink_to_signal_red(
    wide: list[tuple[np.ndarray, object]],
) -> None:
    day = [
        _hsv_of_box(img, lab.bbox)  # type: ignore[attr-defined]
        for img, lab in wide
        if lab.disc and lab.condition == "day" and min(lab.bbox[2:]) >= 10  # type: ignore[attr-defined]
    ]
    sats = [s for _, s, _ in day]
    assert len(day) >= 4
    assert min(sats) < 0.55 and max(sats) > 0.75


def test_wide_snapshot_is_reproducible_and_labelled_inside_the_image() -> None:
    a, la = random_wide_snapshot(11, size=(800, 600))
    b, lb = random_wide_snapshot(11, size=(800, 600))
    assert np.array_equal(a, b) and la == lb
    assert a.shape == (600, 800, 3)
    for i in range(20):
        img, lab = random_wide_snapshot(np.random.default_rng([3, i]))
        if lab.bbox is not None:
            x, y, w, h = lab.bbox
            assert x >= 0 and y >= 0 and x + w <= img.shape[1] and y + h <= img.shape[0]


def test_dataset_generator_a_is_the_randomised_one() -> None:
    sample = next(scenes("A", "train", 1))
    assert sample.source == "A"
    # The reference generator's car colours are names such as "red_brown"; the
    # randomised one's are paint families.
    rng = np.random.default_rng(100_000)
    size_index = int(rng.integers(4))
    image, label = random_wide_snapshot(
        rng, size=((640, 480), (800, 600), (1024, 768), (1280, 720))[size_index]
    )
    assert np.array_equal(image, sample.image) and label.disc == sample.disc


def _disc_candidate(image: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    x, y, w, h = box
    cands = find_candidates(image, PIPELINE_PROFILE)[0]
    near = [
        c
        for c in cands
        if abs(c.bbox[0] + c.bbox[2] / 2 - (x + w / 2)) < w / 2
        and abs(c.bbox[1] + c.bbox[3] / 2 - (y + h / 2)) < h / 2
    ]
    assert near, "the disc must be proposed"
    return max(near, key=lambda c: c.bbox[2] * c.bbox[3]).features


def test_no_feature_is_tied_to_one_cameras_signal_red() -> None:
    assert "in_band_share" not in FEATURE_NAMES and "source" not in FEATURE_NAMES


def test_white_balanced_redness_survives_a_colour_cast() -> None:
    image, label = render_snapshot(
        8, disc=True, condition="day", car_colour="grey", distractors=(), occlusion=0.0
    )
    assert label.bbox is not None
    gains = np.array([1.25, 0.9, 0.8])  # B, G, R: a cold cast, the disc turns pinkish-grey
    cast = np.clip(image * gains[None, None, :], 0, 255).astype(np.uint8)
    plain, shifted = _disc_candidate(image, label.bbox), _disc_candidate(cast, label.bbox)
    wb = FEATURE_NAMES.index("in_wb_redness")
    raw = FEATURE_NAMES.index("in_redness")
    assert abs(shifted[wb] - plain[wb]) < 0.5 * abs(shifted[raw] - plain[raw])


def test_a_cache_of_the_reference_generator_is_not_read(
    tmp_path: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    import cv2

    from tail_check import synth

    old, _ = synth.random_snapshot(np.random.default_rng(100_000))
    cv2.imwrite(str(tmp_path / "A_100000.png"), old)  # type: ignore[operator]
    meta = '{"disc": false, "condition": "day", "kind": "none", "bbox": null}'
    (tmp_path / "A_100000.json").write_text(meta, encoding="utf-8")  # type: ignore[operator]
    monkeypatch.setenv("DEPOT_TAIL_CACHE", str(tmp_path))
    cached = next(scenes("A", "train", 1))
    assert not np.array_equal(cached.image, old)
    again = next(scenes("A", "train", 1))
    assert np.array_equal(cached.image, again.image)
