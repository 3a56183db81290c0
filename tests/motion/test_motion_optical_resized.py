"""The smear meter on resized and cropped frames (found by the independent trial, which
fed resized and cropped versions of the real photos).

* The real photos (RailSem19 cab views, freight-wagon side views; shared/data/real,
  see PROVENANCE.md) show no rolling-shutter stripe pattern: any speed read off them is
  wrong.  Full size they were refused, but shrunk or cropped some passed the gate — its
  straightness limit is in pixels, and a shrunk photo's edges are straighter in pixels —
  and were answered (e.g. 1.6 km/h on a cab view).  The edges of real stripes slant
  alike (the shutter shifts every edge by the same amount); a photo's edges do not: the
  meter now asks that too (``StripeQuality.max_smear_spread``).  Measured: 4–5 of the
  245 versions below answered before (with β given as is, or scaled), 0 now.
* Where the geometry is still measurable it answers: a plain resize by f keeps the
  stripe pattern (β and t_c become β/f and t_c/f), a crop keeps it with the optical
  axis's column; every such version of a stripe frame is measured within 2 %.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

from motion import optical

# shared/data/real beside the repository (its checkout, or a worktree of it further down)
REAL = next(
    (p / "shared" / "data" / "real" for p in Path(__file__).resolve().parents
     if (p / "shared" / "data" / "real").is_dir()),
    Path("/nonexistent"),
)  # fmt: skip
BETA, T_C = 0.94e-3, 1e-4
SCALES = (0.5, 0.25, 2.0)


def _photos() -> list[Path]:
    photos = sorted((REAL / "railsem19_frames").glob("*.jpg"))
    return photos + sorted((REAL / "red_wagons").glob("*.jpg"))


def _resized(img: np.ndarray, f: float) -> np.ndarray:
    h, w = img.shape[:2]
    how = cv2.INTER_AREA if f < 1 else cv2.INTER_LINEAR
    return cv2.resize(img, (round(w * f), round(h * f)), interpolation=how)


def _versions(img: np.ndarray) -> Iterator[tuple[str, np.ndarray, float, float | None]]:
    """(name, frame, scale f, column of the optical axis): the original, three resizes,
    the centre half, the top half, the left half."""
    h, w = img.shape[:2]
    axis = (w - 1) / 2.0
    yield "original", img, 1.0, None
    for f in SCALES:
        yield f"x{f}", _resized(img, f), f, None
    yield "centre", img[h // 4 : 3 * h // 4, w // 4 : 3 * w // 4], 1.0, axis - w // 4
    yield "top", img[: h // 2], 1.0, None
    yield "left", img[:, : w // 2], 1.0, axis


@pytest.mark.skipif(not _photos(), reason="shared/data/real is not on this machine")
def test_no_version_of_a_photo_without_stripes_gets_a_speed() -> None:
    answered = []
    count = 0
    for path in _photos():
        img = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
        assert img is not None, path
        for name, frame, f, axis in _versions(img):
            count += 1
            try:
                r = optical.speed_from_image(
                    frame,
                    distance_m=1.0,
                    pixel_fov_rad=BETA / f,
                    row_time_s=T_C / f,
                    center_col=axis,
                )
            except ValueError:
                continue
            answered.append(f"{path.name[:12]} {name}: {r.speed_kmh:.2f} km/h")
    assert count == 245
    assert not answered, answered


@pytest.mark.parametrize("kmh", [20, 40, 80])
def test_every_resize_and_crop_of_a_stripe_frame_is_measured(kmh: float) -> None:
    img = optical.render_stripes(kmh / 3.6, seed=kmh, noise_sd=4, phase_m=0.017 * kmh)
    for name, frame, f, axis in _versions(img):
        r = optical.speed_from_image(
            frame, distance_m=1.0, pixel_fov_rad=BETA / f, row_time_s=T_C / f, center_col=axis
        )
        assert r.speed_kmh == pytest.approx(kmh, rel=0.02), name
