"""Discs on a body of their own colour, found by their dark rim (a circle search).

Where disc-coloured paint covers much of the search region (a red car) the colour
regions of :mod:`tail_check.regions` merge with the body, and only the disc's outline
separates it: Hough circles on the red channel, each scored by a dark rim between its
inside and its surroundings and by the disc colour inside.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import NDArray

from .profile import CameraProfile
from .regions import DiscCandidate
from .shape import RegionShape, ramp

__all__ = ["rim_candidates"]

MAX_CIRCLES = 16
"""Hough circles checked for a dark rim on a body of the disc's own colour."""
_ANGLES = np.linspace(0.0, 2.0 * math.pi, 48, endpoint=False)
# Sample radii (fractions of r): inside the disc, across its rim, outside it.
_RING_RADII = np.array([0.7, 0.8, 0.9, 0.97, 1.04, 1.11, 1.18, 1.3, 1.4])


def _ring_profiles(
    red: NDArray[np.float32],
    cx: NDArray[np.float64],
    cy: NDArray[np.float64],
    r: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Per circle, the share of directions in which a dark rim separates it from its
    inside (all circles at once)."""
    h, w = red.shape
    radius = r[:, None, None] * _RING_RADII[None, :, None]
    xs = np.clip(np.round(cx[:, None, None] + radius * np.cos(_ANGLES)).astype(int), 0, w - 1)
    ys = np.clip(np.round(cy[:, None, None] + radius * np.sin(_ANGLES)).astype(int), 0, h - 1)
    v = red[ys, xs]
    inside = np.maximum(v[:, 0], v[:, 1])
    rim = v[:, 2:7].min(axis=1)
    outside = np.maximum(v[:, 7], v[:, 8])
    dark = (rim < 0.8 * inside) & ((rim < 0.85 * outside) | (outside < 0.5 * inside))
    return np.asarray(dark.mean(axis=1), dtype=np.float64)


def _rim_candidate(
    redf: NDArray[np.float32],
    band: NDArray[np.bool_],
    smooth: NDArray[np.uint8],
    circle: tuple[float, float, float],
    p: CameraProfile,
    *,
    origin: tuple[int, int],
    scale: float,
    work_side: float,
) -> DiscCandidate:
    """Score one Hough circle: a dark rim around it and the disc colour inside."""
    hx, hy, hr = circle
    # The Hough centre and radius are only good to a pixel or two; the rim test is
    # not, so take the best of a small neighbourhood.
    dx, dy, f = (
        g.ravel() for g in np.meshgrid([-1.5, 0.0, 1.5], [-1.5, 0.0, 1.5], [0.92, 1.0, 1.08])
    )
    cxs, cys, rs = hx + dx, hy + dy, hr * f
    rims = _ring_profiles(redf, cxs, cys, rs)
    best = int(np.lexsort((rs, cys, cxs, rims))[-1])  # the largest, ties as max() on tuples
    rim, cx, cy, r = float(rims[best]), float(cxs[best]), float(cys[best]), float(rs[best])
    disc = np.zeros(band.shape, np.uint8)
    cv2.circle(disc, (round(cx), round(cy)), max(1, round(0.85 * r)), 1, -1)
    inside = disc > 0
    in_band = float(np.count_nonzero(band & inside)) / max(1, int(np.count_nonzero(inside)))
    dmin, dmax = p.disc_diameter_range
    diameter = 2.0 * r / work_side
    score = ramp(rim, 0.6, 0.85) * ramp(in_band, 0.7, 0.9)
    score *= ramp(diameter, 0.7 * dmin, dmin, dmax, 1.3 * dmax)
    side = max(1, int(round(2 * r / scale)))
    bbox = (
        origin[0] + int(round((cx - r) / scale)),
        origin[1] + int(round((cy - r) / scale)),
        side,
        side,
    )
    mean_bgr = smooth[inside].mean(axis=0) if inside.any() else np.zeros(3)
    shape = RegionShape(
        area=math.pi * r**2,
        fill=math.pi / 4,
        ellipse_iou=1.0,
        solidity=1.0,
        aspect=1.0,
        hole_fraction=0.0,
        ellipse_residual=0.0,
    )
    return DiscCandidate(
        bbox=bbox,
        score=score,
        diameter=diameter,
        shape=shape,
        mean_rgb=(float(mean_bgr[2]), float(mean_bgr[1]), float(mean_bgr[0])),
        surround=1.0 - rim,
    )


def rim_candidates(
    band: NDArray[np.bool_],
    smooth: NDArray[np.uint8],
    sharp_red: NDArray[np.uint8],
    p: CameraProfile,
    *,
    origin: tuple[int, int],
    scale: float,
    work_side: float,
) -> list[DiscCandidate]:
    """Discs on a body of their own colour, found by their dark rim (circle search).

    Used only where disc-coloured paint covers much of the search region (a red car):
    there the colour regions merge, and only the disc's outline separates it.
    ``sharp_red`` is the red channel before the full low-pass, where a thin rim
    still shows.
    """
    red = smooth[..., 2]
    dmin, dmax = p.disc_diameter_range
    rmin, rmax = max(3, int(0.5 * dmin * work_side)), int(0.5 * dmax * work_side) + 1
    circles = cv2.HoughCircles(
        red,
        cv2.HOUGH_GRADIENT,
        dp=1,
        minDist=float(rmin),
        param1=60,
        param2=18,
        minRadius=rmin,
        maxRadius=rmax,
    )
    if circles is None:
        return []
    redf = sharp_red.astype(np.float32)
    found = [
        _rim_candidate(
            redf,
            band,
            smooth,
            (float(hx), float(hy), float(hr)),
            p,
            origin=origin,
            scale=scale,
            work_side=work_side,
        )
        for hx, hy, hr in circles[0][:MAX_CIRCLES]
    ]
    return sorted(found, key=lambda c: -c.score)
