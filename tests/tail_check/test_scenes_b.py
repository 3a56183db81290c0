"""Generator B (tail_check.scenes_b): the scene contract other code relies on.

Rendering is deterministic, sizes and dtypes follow the contract, the disc box
is inside the image and red where the disc is, every condition and hard
negative is reachable, conditions are drawn uniformly and every image went
through a JPEG round trip. Small sizes keep the suite fast; the condition and
negative draws do not depend on the size.
"""

from __future__ import annotations

from collections import Counter

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from tail_check.scenes_b import CONDITIONS, NEGATIVE_KINDS, SceneB, iter_scenes, render_scene

SMALL = (400, 300)
TINY = (96, 72)
REQUIRED_CONDITIONS = {"daylight", "overcast", "dusk", "night", "rain", "snow", "fog"}
REQUIRED_KINDS = {"red_lettering", "red_stripe", "red_logo", "red_car_body", "signal_light",
                  "tail_lamp", "hand_wheel", "red_barrier", "none"}


def _red_fraction(scene: SceneB) -> float:
    """Share of bbox pixels whose red clearly dominates green and blue."""
    assert scene.bbox is not None
    x, y, w, h = scene.bbox
    patch = scene.image[y : y + h, x : x + w].astype(np.int32)
    b, g, r = patch[..., 0], patch[..., 1], patch[..., 2]
    return float(np.mean((r > g + 25) & (r > b + 25)))


def _chroma_detail(image: npt.NDArray[np.uint8]) -> float:
    """Fine chroma detail over fine luma detail.

    OpenCV's JPEG encoder subsamples chroma 2×2 (4:2:0), so after a round trip
    the chroma channels carry far less pixel-scale detail than luma; sensor
    noise straight from the camera model has about as much in both.
    """
    ycc = cv2.cvtColor(image, cv2.COLOR_BGR2YCrCb).astype(np.float64)

    def detail(channel: npt.NDArray[np.float64]) -> float:
        return float(np.abs(channel - cv2.blur(channel, (3, 3))).mean())

    return (detail(ycc[..., 1]) + detail(ycc[..., 2])) / 2 / max(detail(ycc[..., 0]), 1e-9)


def test_same_seed_same_scene_and_different_seeds_differ() -> None:
    first = render_scene(11, size=SMALL)
    again = render_scene(11, size=SMALL)
    other = render_scene(12, size=SMALL)
    assert np.array_equal(first.image, again.image)
    assert (first.disc, first.bbox, first.condition, first.negative_kind) == (
        again.disc, again.bbox, again.condition, again.negative_kind)
    assert not np.array_equal(first.image, other.image)


def test_iter_scenes_is_deterministic_and_counts() -> None:
    two = list(iter_scenes(2, seed=5))
    one = list(iter_scenes(1, seed=5))
    assert len(two) == 2 and len(one) == 1
    assert np.array_equal(two[0].image, one[0].image) and two[0].bbox == one[0].bbox
    assert not np.array_equal(two[0].image[:8, :8], two[1].image[:8, :8]) or (
        two[0].image.shape != two[1].image.shape)
    assert list(iter_scenes(0, seed=5)) == []


@pytest.mark.parametrize("seed", [0])
def test_drawn_size_is_4_3_or_16_9_within_range(seed: int) -> None:
    image = render_scene(seed).image
    h, w = image.shape[:2]
    assert image.dtype == np.uint8 and image.shape[2] == 3
    assert 800 <= w <= 1920 and 600 <= h <= 1080
    assert min(abs(w / h - 4 / 3), abs(w / h - 16 / 9)) < 0.01


def test_size_override_is_width_height() -> None:
    scene = render_scene(3, size=(432, 240))
    assert scene.image.shape == (240, 432, 3) and scene.image.dtype == np.uint8


@pytest.mark.parametrize("condition", ["daylight", "overcast"])
def test_disc_box_is_inside_the_image_and_red(condition: str) -> None:
    fractions = []
    for seed in range(8):
        scene = render_scene(seed, disc=True, condition=condition, size=SMALL)
        assert scene.disc and scene.bbox is not None and scene.negative_kind is None
        x, y, w, h = scene.bbox
        assert x >= 0 and y >= 0 and w >= 1 and h >= 1
        assert x + w <= SMALL[0] and y + h <= SMALL[1]
        fractions.append(_red_fraction(scene))
    # Daylight discs are red over most of their box (rim, reflector, snow, poles aside).
    assert np.median(fractions) > 0.35, fractions
    assert min(fractions) > 0.1, fractions


def test_disc_box_scales_with_the_image() -> None:
    """Disc radius stays within about 1.5–8 % of the image height."""
    for seed in range(12):
        scene = render_scene(seed, disc=True, size=(240, 180))
        assert scene.bbox is not None
        radius = max(scene.bbox[2], scene.bbox[3]) / 2 / 180
        assert 0.008 <= radius <= 0.11, (seed, scene.bbox)


def test_scene_without_disc_has_no_box_and_a_kind() -> None:
    for seed in range(6):
        scene = render_scene(seed, disc=False, size=TINY)
        assert not scene.disc and scene.bbox is None
        assert scene.negative_kind in NEGATIVE_KINDS


def test_contract_lists_cover_the_required_names() -> None:
    assert set(CONDITIONS) >= REQUIRED_CONDITIONS
    assert set(NEGATIVE_KINDS) >= REQUIRED_KINDS


def test_conditions_uniform_and_discs_half_the_time() -> None:
    scenes = [render_scene(seed, size=TINY) for seed in range(200)]
    counts = Counter(s.condition for s in scenes)
    assert set(counts) == set(CONDITIONS)
    expected = 200 / len(CONDITIONS)
    # Binomial sd ≈ 4.6 for 28.6 expected; 3 sd either side.
    assert all(abs(c - expected) < 15 for c in counts.values()), counts
    discs = sum(s.disc for s in scenes)
    assert 80 <= discs <= 120  # p = 0.5, sd ≈ 7


def test_every_negative_kind_is_reachable() -> None:
    seen: set[str] = set()
    for seed in range(300):
        kind = render_scene(seed, disc=False, size=TINY).negative_kind
        assert kind is not None
        seen.add(kind)
        if seen == set(NEGATIVE_KINDS):
            break
    assert seen == set(NEGATIVE_KINDS)


@pytest.mark.parametrize("condition", sorted(REQUIRED_CONDITIONS))
def test_every_condition_renders_with_and_without_disc(condition: str) -> None:
    with_disc = render_scene(21, disc=True, condition=condition, size=(240, 180))
    without = render_scene(21, disc=False, condition=condition, size=(240, 180))
    assert with_disc.condition == without.condition == condition
    assert with_disc.bbox is not None and without.bbox is None
    # Not a blank frame: some structure survives even at night or in fog.
    assert float(with_disc.image.std()) > 2.0 and float(without.image.std()) > 2.0


def test_images_went_through_jpeg() -> None:
    """Every scene shows JPEG's chroma subsampling; the same content with fresh
    per-channel sensor noise and no JPEG does not."""
    rng = np.random.default_rng(0)
    for seed in range(4):
        image = render_scene(seed, size=(480, 360)).image
        assert _chroma_detail(image) < 0.3, seed  # measured 0.04-0.11
        raw = cv2.GaussianBlur(image.astype(np.float64), (0, 0), 2.0)
        raw = np.clip(raw + rng.normal(0.0, 4.0, raw.shape), 0, 255).astype(np.uint8)
        assert _chroma_detail(raw) > 0.5, seed  # measured about 0.93-0.96


def test_bad_arguments_are_refused_with_the_fix_named() -> None:
    with pytest.raises(ValueError, match="daylight"):
        render_scene(1, condition="sunny")
    with pytest.raises(ValueError, match="non-negative"):
        render_scene(-1)
    with pytest.raises(ValueError, match="minimum"):
        render_scene(1, size=(10, 10))
    with pytest.raises(ValueError, match="non-negative"):
        list(iter_scenes(-1, seed=0))
