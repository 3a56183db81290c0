"""An unlit lamp sits in a housing; a tail disc hangs on a bracket.

An unlit red tail or marker lamp is a red lens of disc size, round and filled: the
hand-tuned detector's idea of a disc, and the learned verifiers believed several (the
independent trial's unlit lamps). What the lens has and a disc has not is its housing:
a dark ring or box around the lens, wider than a disc's rim (a painted rim is a few
hundredths of the radius to a tenth), ending in the body's colour. A disc's surround is
the car body (or the sky, the ballast) right past its rim, except where its bracket and
the buffer beam below it are.

:func:`housing_reason` measures, along rays from the region's centre, how far a dark
surround reaches past the field, and gives the reason to hold a ``present`` uncertain
when, in most directions, it reaches as far as a housing does and then ends. It only
ever leans towards safety: on a dark body (a black tank car, or at night) the
surround never ends and nothing is held. Measured on the 389 hand-tuned ``present`` on
true discs of generators A, B and C (340000-340119 each, A's randomised mode
340000-340119 and 201000-202399, B 201000-201199) that the lettering checks leave: it
holds none (before the grey test, one: A:201101, whose box was on the pale reflector).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from ._lettering_ink import BBox, chroma2

__all__ = ["HOUSING", "HousingParams", "housing_extent", "housing_reason"]


@dataclass(frozen=True)
class HousingParams:
    """What counts as a lamp's housing around a disc-shaped region.

    Attributes
    ----------
    work_radius : the region is judged at a scale where its radius is this many pixels
        to twice that (or its own, when smaller).
    min_side_px : boxes smaller than this are not judged.
    rays : directions sampled around the centre.
    start, stop : each ray is sampled from ``start`` to ``stop`` times the region's
        radius, every ``step`` working pixels.
    step : see ``start``.
    darker : a surround pixel is dark (a housing's) when its lightness (CIELAB, OpenCV's
        8-bit scale) is at least this far below the region's field's median.
    grey_chroma : ... and grey or black: its chroma is at most this (a housing is black,
        grey or dark body paint; the red field of a disc around a pale reflector is not).
    ends : the housing ends where, past it, a pixel is at least ``ends`` lighter than the
        dark surround's median (the body's colour or a chrome bezel beyond it).
    min_extent : in a housing, the dark surround reaches at least this many radii from
        the centre (a disc's painted rim ends by 1.15).
    share : ... and ends, in at least this share of the rays (a bracket, the buffer
        beam below a disc or a pole cover fewer).
    """

    work_radius: int = 24
    min_side_px: int = 10
    rays: int = 32
    start: float = 1.0
    stop: float = 2.2
    step: float = 0.5
    darker: float = 35.0
    grey_chroma: float = 25.0
    ends: float = 35.0
    min_extent: float = 1.4
    share: float = 0.6


HOUSING = HousingParams()


def _lightness_rays(
    image_bgr: NDArray[np.uint8], box: BBox, p: HousingParams
) -> tuple[NDArray[np.float32], float, NDArray[np.float32]] | None:
    """Lightness along each ray (rays, samples), the field's median lightness and the
    samples' distances from the centre in radii; None when the box is too small."""
    x, y, w, h = box
    if min(w, h) < p.min_side_px:
        return None
    radius = (w + h) / 4.0
    reach = int(np.ceil(p.stop * radius)) + 2
    cx, cy = x + w / 2.0, y + h / 2.0
    x0, y0 = max(0, int(cx) - reach), max(0, int(cy) - reach)
    crop = image_bgr[y0 : int(cy) + reach, x0 : int(cx) + reach]
    if crop.size == 0:
        return None
    # An integer reduction (OpenCV's fast path of INTER_AREA: block means) to a radius
    # of ``work_radius`` to twice that.
    factor = max(1, int(radius // p.work_radius))
    scale = 1.0 / factor
    if factor > 1:
        rows, cols = crop.shape[0] // factor, crop.shape[1] // factor
        crop = np.asarray(
            cv2.resize(
                crop[: rows * factor, : cols * factor], (cols, rows), interpolation=cv2.INTER_AREA
            ),
            np.uint8,
        )
    lab = cv2.cvtColor(np.ascontiguousarray(crop), cv2.COLOR_BGR2LAB).astype(np.float32)
    # A colourful surround is paint (a disc's field around its reflector), never a
    # housing: it is lifted out of the dark range.
    grey = chroma2(lab) <= p.grey_chroma**2
    lightness = np.where(grey, lab[..., 0], np.float32(255.0)).astype(np.float32)
    r = radius * scale
    centre = ((cx - x0) * scale - 0.5, (cy - y0) * scale - 0.5)
    radii = np.arange(p.start, p.stop + 1e-9, p.step / r, dtype=np.float32)
    angles = np.linspace(0.0, 2.0 * np.pi, p.rays, endpoint=False)
    xs = centre[0] + r * radii[None, :] * np.cos(angles)[:, None]
    ys = centre[1] + r * radii[None, :] * np.sin(angles)[:, None]
    rays = cv2.remap(
        lightness,
        xs.astype(np.float32),
        ys.astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    inner = cv2.remap(
        np.ascontiguousarray(lab[..., 0]),
        (centre[0] + 0.6 * r * np.cos(angles)).astype(np.float32)[None, :],
        (centre[1] + 0.6 * r * np.sin(angles)).astype(np.float32)[None, :],
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    )
    return np.asarray(rays, np.float32), float(np.median(inner)), radii


def housing_extent(
    image_bgr: NDArray[np.uint8], box: BBox, *, params: HousingParams = HOUSING
) -> NDArray[np.float32]:
    """How far a dark surround reaches from the region's centre, in radii, per ray.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8, BGR
        The image (not modified).
    box : (x, y, w, h)
        The disc-shaped region, in pixels of ``image_bgr``.
    params : the rays and what counts as dark.

    Returns
    -------
    ndarray, shape (rays,), float32
        Per ray, the distance (radii) at which the dark surround ends, or ``inf`` where
        it does not end within ``stop`` radii, or 0 where the surround is not dark at all;
        empty when the box is too small to judge.
    """
    found = _lightness_rays(image_bgr, box, params)
    if found is None:
        return np.zeros(0, np.float32)
    rays, field, radii = found
    dark = rays <= field - params.darker
    level = float(np.median(rays[dark])) if dark.any() else field
    lighter = rays >= level + params.ends
    # The dark run starts within the rim (its first fifth of a radius) or not at all;
    # it ends at the first lighter sample after its start.
    first = np.argmax(dark, axis=1)
    starts = dark.any(axis=1) & (radii[first] <= params.start + 0.2)
    columns = np.arange(rays.shape[1])[None, :]
    after = lighter & (columns >= first[:, None])
    ended = after.any(axis=1)
    end = np.where(ended, radii[np.argmax(after, axis=1)], np.float32(np.inf))
    return np.asarray(np.where(starts, end, np.float32(0.0)), np.float32)


def housing_reason(
    image_bgr: NDArray[np.uint8], box: BBox, *, params: HousingParams = HOUSING
) -> str | None:
    """Why the region is a lamp's lens in its housing rather than a disc, or None."""
    extent = housing_extent(image_bgr, box, params=params)
    if extent.size == 0:
        return None
    housed = np.isfinite(extent) & (extent >= params.min_extent)
    if float(housed.mean()) < params.share:
        return None
    reach = float(np.median(extent[housed]))
    return (
        f"a dark surround {reach:.1f} radii wide rings the disc-shaped region, as a lamp's "
        "housing does (a tail disc's rim is narrow); a person must look"
    )
