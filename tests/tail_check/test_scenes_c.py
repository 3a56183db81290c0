"""Generator C: determinism, sizes, conditions, negatives and disc boxes."""

from __future__ import annotations

import numpy as np
import pytest

from tail_check.scenes_c import CONDITIONS, NEGATIVE_KINDS, SceneC, render_scene

SMALL = (640, 480)


def test_api_lists() -> None:
    for c in ("daylight", "overcast", "dusk", "night", "rain", "snow", "fog"):
        assert c in CONDITIONS
    for k in (
        "none",
        "red_lettering",
        "red_stripe",
        "red_logo",
        "red_car_body",
        "signal_light",
        "tail_lamp",
        "hand_wheel",
        "red_barrier",
    ):
        assert k in NEGATIVE_KINDS


def test_deterministic() -> None:
    a = render_scene(7, size=SMALL)
    b = render_scene(7, size=SMALL)
    assert np.array_equal(a.image, b.image)
    assert (a.disc, a.bbox, a.condition, a.negative_kind) == (
        b.disc,
        b.bbox,
        b.condition,
        b.negative_kind,
    )


def test_random_sizes() -> None:
    for seed in range(3):
        sc = render_scene(seed)
        h, w = sc.image.shape[:2]
        assert 640 <= w <= 1920 and 480 <= h <= 1080
        assert sc.image.dtype == np.uint8 and sc.image.shape[2] == 3


@pytest.mark.parametrize("cond", CONDITIONS)
def test_every_condition(cond: str) -> None:
    for disc in (True, False):
        sc = render_scene(11, disc=disc, condition=cond, size=SMALL)
        assert sc.image.shape == (480, 640, 3)
        assert sc.condition == cond and sc.disc is disc
        _check_labels(sc)


def _check_labels(sc: SceneC) -> None:
    h, w = sc.image.shape[:2]
    if sc.disc:
        assert sc.bbox is not None and sc.negative_kind is None
        x, y, bw, bh = sc.bbox
        assert x >= 0 and y >= 0 and x + bw <= w and y + bh <= h and bw > 0 and bh > 0
    else:
        assert sc.bbox is None and sc.negative_kind in NEGATIVE_KINDS


def test_every_negative_kind_renders() -> None:
    seen: set[str] = set()
    seed = 0
    while len(seen) < len(NEGATIVE_KINDS) and seed < 300:
        sc = render_scene(seed, disc=False, condition="daylight", size=(320 * 2, 240 * 2))
        assert sc.negative_kind is not None
        seen.add(sc.negative_kind)
        seed += 1
    assert seen == set(NEGATIVE_KINDS)


def test_disc_bbox_reddish_in_daylight() -> None:
    for seed in range(6):
        sc = render_scene(seed, disc=True, condition="daylight", size=SMALL)
        assert sc.bbox is not None
        x, y, bw, bh = sc.bbox
        patch = sc.image[y + bh // 4 : y + 3 * bh // 4 + 1, x + bw // 4 : x + 3 * bw // 4 + 1]
        b, g, r = (float(v) for v in patch.reshape(-1, 3).mean(axis=0))
        assert r > g + 25 and r > b + 25, (seed, b, g, r)
        assert 0.01 * 480 <= bh <= 0.1 * 480
