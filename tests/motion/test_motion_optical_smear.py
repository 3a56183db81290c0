"""The smear meter measures the slant the frame shows (found by the
independent trial: stripes moving exactly 100 px over 836 rows read as
116.9 px, the speed 17 % high, and the spec's 796 px example as "no
stripes found").  Synthetic frames of a rectilinear lens (the same shift in
pixels on every edge), several sizes, and the spec's 40 km/h example."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motion import optical

BETA, T_C, D = 0.94e-3, 1e-4, 1.0


def _frame(h: int, w: int, smear_px: float, period: int = 200, width: int = 70) -> np.ndarray:
    """Bright stripes whose edges move ``smear_px`` to higher columns over ``h`` rows."""
    r = np.arange(h)[:, None]
    c = np.arange(w)[None, :]
    x = c - smear_px * r / h
    g = np.where(np.mod(x, period) < width, 220.0, 30.0)
    g = g + np.random.default_rng(h + w).normal(0.0, 2.0, g.shape)
    return np.clip(g, 0, 255).astype(np.uint8)


@pytest.mark.parametrize(
    ("h", "w", "smear"),
    [(836, 1400, 100.0), (836, 1400, 20.0), (836, 1400, 50.0), (400, 1400, 50.0), (400, 640, 30.0)],
)
def test_the_measured_smear_is_the_frames(h: int, w: int, smear: float) -> None:
    r = optical.speed_from_image(
        _frame(h, w, smear), distance_m=D, pixel_fov_rad=BETA, row_time_s=T_C
    )
    expected = math.tan(smear * BETA) * D / (h * T_C)  # eq. 14
    # edges moving to higher columns down the frame: the camera moves towards
    # lower columns, a negative speed (motion.stripes: positive towards increasing column)
    assert r.smear_px == pytest.approx(-smear, abs=0.5)
    assert r.speed_mps == pytest.approx(-expected, rel=0.01)
    assert abs(r.speed_mps + expected) <= 3 * max(r.sigma_mps, r.fit_sigma_mps)


def test_the_spec_example_40_kmh_796_px() -> None:
    h = optical.rows_for_stripe(1.0, D, BETA)
    assert h == 836
    r = optical.speed_from_image(
        _frame(h, 1400, -796.0), distance_m=D, pixel_fov_rad=BETA, row_time_s=T_C
    )
    assert r.smear_px == pytest.approx(796.0, abs=2.0)
    assert r.speed_kmh == pytest.approx(40.0, rel=0.01)
