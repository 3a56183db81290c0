"""Camera calibration: a profile from one snapshot and a point inside the disc."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import numpy as np
from numpy.typing import NDArray

from .colour import band_mask
from .detect import WORK_SIDE, check_image
from .profile import DEFAULT_PROFILE, CameraProfile

__all__ = ["calibrate"]

_CALIBRATION_GAIN = (0.75, 1.3)


def _disc_region(
    smooth: NDArray[np.uint8],
    point: tuple[int, int],
    ref_rgb: tuple[float, float, float],
    c_delta: float,
) -> NDArray[np.bool_]:
    mask = band_mask(smooth, ref_rgb, c_delta, gain_range=_CALIBRATION_GAIN).view(np.uint8)
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    label = int(labels[point[1], point[0]])
    if label == 0:
        raise ValueError(
            "the disc point is not inside a region of its own colour; click inside the disc"
        )
    return np.asarray(labels == label)


def _locate_disc(
    image: NDArray[np.uint8], point: tuple[float, float], p: CameraProfile
) -> tuple[NDArray[np.uint8], NDArray[np.bool_], tuple[int, int]]:
    """Working-scale low-passed image, the disc region around ``point``, and the size."""
    height, width = image.shape[:2]
    scale = WORK_SIDE / math.sqrt(width * height)
    size = (max(1, round(width * scale)), max(1, round(height * scale)))
    work = cv2.resize(image, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    smooth = np.asarray(cv2.GaussianBlur(work, (0, 0), max(0.3, p.sigma * WORK_SIDE)), np.uint8)
    px = min(size[0] - 1, int(point[0] * scale))
    py = min(size[1] - 1, int(point[1] * scale))
    patch = smooth[max(0, py - 1) : py + 2, max(0, px - 1) : px + 2].reshape(-1, 3)
    seed_bgr = np.median(patch, axis=0)
    seed_rgb = (float(seed_bgr[2]), float(seed_bgr[1]), float(seed_bgr[0]))
    if sum(seed_rgb) < 15:
        raise ValueError("the disc point is almost black; pick a point on the lit red disc")
    if seed_rgb[0] < 1.4 * max(seed_rgb[1], seed_rgb[2]):
        raise ValueError(
            f"the colour at the disc point (RGB {seed_rgb[0]:.0f}, {seed_rgb[1]:.0f}, "
            f"{seed_rgb[2]:.0f}) is not red; click inside the red disc"
        )
    return smooth, _disc_region(smooth, (px, py), seed_rgb, p.c_delta), size


def calibrate(
    image_bgr: NDArray[np.uint8],
    disc_xy: tuple[float, float],
    *,
    base: CameraProfile | None = None,
    name: str = "calibrated",
    margin: float = 1.5,
) -> CameraProfile:
    """Build a camera profile from a snapshot and a point inside its tail disc.

    As in the paper, ``c_ref`` is picked inside the disc on a sample image; the disc
    found around the point also fixes the search region (the disc box widened by
    ``margin`` disc diameters on each side) and the expected size (0.65-1.5 times
    the measured diameter).

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
        The calibration snapshot, BGR. Not modified.
    disc_xy : (x, y)
        A pixel inside the disc (not on the reflector), in image pixels.
    base : CameraProfile, optional
        Profile whose other settings (c_Δ, σ, thresholds) are kept; the default one
        when omitted.
    name : str
        Name of the new profile.
    margin : float
        Search-region margin around the disc, in disc diameters.

    Returns
    -------
    CameraProfile

    Raises
    ------
    ValueError
        If the point is outside the image or not on a disc-sized region of one colour.
    """
    image = check_image(image_bgr)
    p = base if base is not None else DEFAULT_PROFILE
    height, width = image.shape[:2]
    x, y = float(disc_xy[0]), float(disc_xy[1])
    if not (0 <= x < width and 0 <= y < height):
        raise ValueError(f"disc point ({x:g}, {y:g}) is outside the {width}x{height} image")
    smooth, region, size = _locate_disc(image, (x, y), p)
    ys, xs = np.nonzero(region)
    diameter = math.sqrt(4.0 * xs.size / math.pi) / WORK_SIDE
    dmin, dmax = p.disc_diameter_range
    if not (0.5 * dmin <= diameter <= 2.0 * dmax):
        raise ValueError(
            f"the region around the point has a diameter of {diameter:.3f} of the image side, "
            "not a disc; click inside the disc, or pass a base profile with another size range"
        )
    ref_bgr = np.median(smooth[region], axis=0)
    d_px = diameter * WORK_SIDE
    x0 = max(0.0, (xs.min() - margin * d_px) / size[0])
    x1 = min(1.0, (xs.max() + 1 + margin * d_px) / size[0])
    y0 = max(0.0, (ys.min() - margin * d_px) / size[1])
    y1 = min(1.0, (ys.max() + 1 + margin * d_px) / size[1])
    return replace(
        p,
        name=name,
        reference_rgb=(
            round(float(ref_bgr[2]), 1),
            round(float(ref_bgr[1]), 1),
            round(float(ref_bgr[0]), 1),
        ),
        search_region=(round(x0, 4), round(y0, 4), round(x1, 4), round(y1, 4)),
        disc_diameter_range=(round(0.65 * diameter, 4), round(1.5 * diameter, 4)),
    )
