"""Synthetic rolling-shutter frames of vertical stripes (an equiangular lens:
column ∝ angle), for tests and benchmarks; re-exported by :mod:`motion.stripes`
and :mod:`motion.optical`."""

from __future__ import annotations

import math

import cv2
import numpy as np
import numpy.typing as npt

__all__ = ["render_stripes"]


def render_stripes(
    speed_mps: float,
    *,
    distance_m: float = 1.0,
    pixel_fov_rad: float = 0.94e-3,
    row_time_s: float = 1e-4,
    width: int = 1920,
    height: int = 1080,
    stripe_period_m: float = 0.40,
    stripe_width_m: float = 0.12,
    stripe_height_m: float = 0.9,
    phase_m: float = 0.0,
    exposure_s: float = 2e-5,
    preslant_mps: float = 0.0,
    blur_px: float = 0.7,
    noise_sd: float = 3.0,
    dark: float = 30.0,
    bright: float = 220.0,
    supersample: int = 4,
    seed: int | None = None,
) -> npt.NDArray[np.uint8]:
    """A synthetic rolling-shutter frame of bright vertical stripes beside the line.

    The camera looks sideways at a plane ``distance_m`` away, moving along
    it at ``speed_mps`` (positive: towards increasing column).  Row ``r`` is
    exposed during ``[r·t_c, r·t_c + exposure_s]``.  Each pixel integrates
    ``supersample`` sub-columns × ``supersample`` instants of its exposure,
    then the frame gets a Gaussian lens blur of ``blur_px`` and additive
    noise of ``noise_sd`` grey levels.  Stripes are ``stripe_height_m`` tall,
    centred on the optical axis.  ``preslant_mps`` paints the stripes
    slanted against the smear so that they look straight at that speed.
    """
    if width < 8 or height < 8:
        raise ValueError("image too small")
    rng = np.random.default_rng(seed)
    cx = (width - 1) / 2.0
    cy = (height - 1) / 2.0
    cols = np.arange(width, dtype=np.float64)
    rows = np.arange(height, dtype=np.float64)[:, None]
    ss = max(1, int(supersample))
    acc = np.zeros((height, width), dtype=np.float64)
    for i in range(ss):
        dc = (i + 0.5) / ss - 0.5
        x_ray = distance_m * np.tan((cols + dc - cx) * pixel_fov_rad)[None, :]
        for j in range(ss):
            t = rows * row_time_s + (j + 0.5) / ss * exposure_s
            # Along-track coordinate of the stripe plane seen by the ray.
            x = x_ray + speed_mps * t
            # Pre-slanted stripes: the painted edge is shifted with height so
            # that the rolling shutter straightens it at ``preslant_mps``.
            x = x - preslant_mps * rows * row_time_s + phase_m
            inside = np.mod(x, stripe_period_m) < stripe_width_m
            acc += inside
    acc /= ss * ss
    half_rows = math.atan(stripe_height_m / 2 / distance_m) / pixel_fov_rad
    vis = (np.abs(rows - cy) <= half_rows).astype(np.float64)
    img = dark + (bright - dark) * acc * vis
    if blur_px > 0:
        img = np.asarray(cv2.GaussianBlur(img, (0, 0), blur_px), dtype=np.float64)
    if noise_sd > 0:
        img = img + rng.normal(0.0, noise_sd, img.shape)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)
