"""Stage 1: candidate discs proposed by illumination-robust colour maps, at many scales.

The paper's band ``c_ref ± c_Δ`` is tied to one camera's light; a disc at dusk, in fog,
under a lit reflector or in another paint leaves it. The maps here depend on colour
*ratios*, not on brightness:

* ``redness`` — HSV saturation restricted to red hues, ``(R - max(G, B)) / R``;
* ``chroma`` — the chromaticity ``r = R / (R + G + B)``;
* ``value`` — ``max(R, G, B)`` divided by the crop's own bright level (auto exposure);
* ``evidence`` — ``redness`` times a soft ramp of ``value`` (a dark rim is no disc paint).

Two kinds of proposals, both as circles ``(cx, cy, r)`` in working pixels:

1. *blobs*: centre-surround differences of ``evidence`` at a geometric ladder of radii
   (small and large discs alike, and a disc on a red body by its darker rim);
2. *regions*: connected components of ``chroma``/``redness`` masks at several strictness
   levels (a disc is often more saturated than the red-brown body it is mounted on),
   unioned with the paper's band.

Proposals only propose; the verifier decides.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from ..colour import band_mask
from ..labels import label_areas, label_box, label_centroid, label_regions
from ..pixels import median_u8, quantile_f32_u8
from ..profile import CameraProfile

__all__ = ["Maps", "Proposal", "ProposalParams", "make_maps", "propose", "region_box"]

F32 = NDArray[np.float32]


@dataclass(frozen=True)
class ProposalParams:
    """Parameters of the proposal stage (lengths as fractions of the working side).

    Attributes
    ----------
    work_side : float
        Geometric-mean side ``sqrt(w*h)`` of the working crop, pixels.
    bright_quantile : float
        Quantile of ``max(R,G,B)`` taken as the crop's bright level (auto exposure).
    min_bright : float
        Floor of that bright level, 0..1 (a black frame is not stretched into noise).
    clip_level : float
        Low-passed ``max(R,G,B)`` (0..255) at or above which a pixel counts as clipped:
        a lamp emits light and saturates the sensor, paint in daylight rarely does.
    value_knee : float
        Normalised value at which ``evidence`` reaches full weight.
    blob_radii : tuple of float
        Radii of the centre-surround ladder.
    centre_sigma, surround_sigma : float
        Half-sides of the centre and surround box means, in radii.
    min_response : float
        Minimum centre-surround difference of ``evidence`` for a blob.
    lit_radii, min_lit_response : the same for bright spots of ``value`` (a lit
        reflector at night, a reflector brighter than its disc at dusk).
    levels : tuple of (float, float)
        ``(chromaticity r, redness)`` minima of the region masks, loose to strict.
    radius_range : (float, float)
        Radii kept.
    max_blobs, max_regions : int
        Strongest blobs / largest regions kept per scale or level.
    """

    work_side: float = 320.0
    bright_quantile: float = 0.99
    min_bright: float = 0.12
    clip_level: float = 245.0
    value_knee: float = 0.35
    blob_radii: tuple[float, ...] = (0.008, 0.012, 0.018, 0.027, 0.04, 0.06, 0.09)
    centre_sigma: float = 0.7
    surround_sigma: float = 1.8
    min_response: float = 0.06
    lit_radii: tuple[float, ...] = (0.006, 0.010, 0.016, 0.025)
    min_lit_response: float = 0.2
    levels: tuple[tuple[float, float], ...] = ((0.40, 0.30), (0.50, 0.55), (0.62, 0.75))
    radius_range: tuple[float, float] = (0.006, 0.14)
    max_blobs: int = 8
    max_regions: int = 4


PROPOSAL_PARAMS = ProposalParams()
LIT_SOURCE = 9
"""Source number of bright-spot proposals."""
EPS = 1.0
"""Added to colour sums (0..255 scale) so black pixels do not divide by zero."""


@dataclass(frozen=True)
class Maps:
    """Working-scale maps of one crop (float32, 0..1 unless stated).

    Attributes
    ----------
    bgr : low-passed colour, 0..255.
    redness, chroma, value, evidence : see the module docstring.
    band : the paper's band mask.
    bright : the crop's bright level before normalisation, 0..1 (night is low).
    origin, scale : crop origin in image pixels and image-to-working scale.
    """

    bgr: F32
    redness: F32
    chroma: F32
    value: F32
    evidence: F32
    band: NDArray[np.bool_]
    bright: float
    origin: tuple[int, int]
    scale: float
    work_side: float
    stack: F32
    """(h, w, 9): 1, redness, chroma, value, evidence, band, redness², white-balanced
    redness, clipped (for zone sums)."""


@dataclass(frozen=True)
class Proposal:
    """A proposed disc: centre and radius in working pixels, its source and strength."""

    cx: float
    cy: float
    r: float
    source: int
    """0 evidence blob, 1.. region mask level (1-based), ``len(levels) + 1`` the paper's
    band, :data:`LIT_SOURCE` a bright spot (a lit reflector, segmented on ``value``)."""
    response: float


def region_box(p: CameraProfile, width: int, height: int) -> tuple[int, int, int, int]:
    x0, y0, x1, y1 = p.search_region
    x, y = int(round(x0 * width)), int(round(y0 * height))
    w = max(1, int(round(x1 * width)) - x)
    h = max(1, int(round(y1 * height)) - y)
    return x, y, min(w, width - x), min(h, height - y)


def _working(
    image: NDArray[np.uint8], p: CameraProfile, c: ProposalParams
) -> tuple[NDArray[np.uint8], tuple[int, int], float]:
    """The search region resampled to the working scale and low-passed, its origin in
    image pixels and the image-to-working scale."""
    height, width = image.shape[:2]
    x, y, w, h = region_box(p, width, height)
    scale = c.work_side / math.sqrt(width * height)
    size = (max(8, round(w * scale)), max(8, round(h * scale)))
    interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
    work = cv2.resize(image[y : y + h, x : x + w], size, interpolation=interp)
    sigma_px = p.sigma * c.work_side
    if sigma_px >= 0.3:
        work = cv2.GaussianBlur(work, (0, 0), sigma_px)
    return np.asarray(work, np.uint8), (x, y), scale


def _ratio(num: F32, den: F32) -> F32:
    """``clip(num / (den + EPS), 0, 1)``, in place of ``num``."""
    np.divide(num, den + EPS, out=num)
    return np.asarray(np.clip(num, 0.0, 1.0, out=num), np.float32)


def make_maps(
    image: NDArray[np.uint8], p: CameraProfile, c: ProposalParams = PROPOSAL_PARAMS
) -> Maps:
    """Crop the search region, resample to the working scale, low-pass and build the maps.

    Every map is computed on contiguous colour planes (element-wise float32 operations:
    the same values as on the interleaved image's channels, in a fraction of the time).
    """
    work_u8, origin, scale = _working(image, p, c)
    band = band_mask(work_u8, p.reference_rgb, p.c_delta, gain_range=p.gain_range)
    planes_u8 = [np.asarray(ch, np.uint8) for ch in cv2.split(work_u8)]
    b, g, r = (np.asarray(ch, np.float32) for ch in planes_u8)
    top_u8 = np.asarray(cv2.max(cv2.max(planes_u8[0], planes_u8[1]), planes_u8[2]), np.uint8)
    top = top_u8.astype(np.float32)
    redness = _ratio(r - np.maximum(g, b), r)
    chroma = r / (r + g + b + 3 * EPS)
    # Histogram statistics of the uint8 crop: numpy's quantile and median, bit for bit.
    bright = max(c.min_bright, quantile_f32_u8(top_u8, c.bright_quantile) / 255.0)
    value = np.asarray(np.clip(top / (255.0 * bright), 0.0, 1.0), np.float32)
    evidence = np.asarray(redness * np.clip(value / c.value_knee, 0.0, 1.0), np.float32)
    red_wb = _grey_world_redness((b, g, r), planes_u8)
    layers = (redness, chroma, value, evidence, band, redness**2, red_wb, top >= c.clip_level)
    ones = np.ones_like(redness)
    stack = cv2.merge([ones, *(np.asarray(layer, np.float32) for layer in layers)])
    bgr = cv2.merge([b, g, r])
    return Maps(
        np.asarray(bgr, np.float32),
        redness,
        chroma,
        value,
        evidence,
        band,
        bright,
        origin,
        scale,
        c.work_side,
        np.asarray(stack, np.float32),
    )


def _grey_world_redness(bgr: tuple[F32, F32, F32], work: Sequence[NDArray[np.uint8]]) -> F32:
    """Redness of the crop white-balanced by the grey-world rule (each channel's median to
    their mean): a camera's colour cast or a dusk light does not make every surface
    redder. ``bgr`` are the crop's planes, ``work`` the same as uint8 (its medians come
    from histograms)."""
    med = np.array([median_u8(plane) for plane in work], np.float32) + EPS
    gains = (float(med.mean()) / med).astype(np.float32)
    b, g, r = (plane * gains[k] for k, plane in enumerate(bgr))
    return _ratio(r - np.maximum(g, b), r)


def _peaks(diff: F32, size: int, floor: float) -> NDArray[np.int32] | None:
    """(x, y) of the pixels of ``diff`` (h, w) at or above ``floor`` that are the maximum
    of their ``size`` x ``size`` square, in row-major order (None: no such pixel).

    The square maximum is taken only over the box of the pixels at or above ``floor``,
    grown by half the square (the rest of the frame cannot hold a peak): the very
    values of the whole frame's, as a maximum does not depend on where it is taken and
    OpenCV's dilation ignores what lies outside the image.
    """
    above = diff >= floor
    bx, by, bw, bh = cv2.boundingRect(above.view(np.uint8))
    if bw == 0 or bh == 0:
        return None
    half = size // 2
    x0, y0 = max(0, bx - half), max(0, by - half)
    x1, y1 = min(diff.shape[1], bx + bw + half), min(diff.shape[0], by + bh + half)
    win = diff[y0:y1, x0:x1]
    peaks = (win >= cv2.dilate(win, np.ones((size, size), np.uint8))) & above[y0:y1, x0:x1]
    # OpenCV lists the peaks in numpy's row-major order, tens of times faster.
    where = cv2.findNonZero(peaks.view(np.uint8))
    if where is None:
        return None
    return np.asarray(where.reshape(-1, 2) + np.array([x0, y0], np.int32), np.int32)


def _blobs(m: Maps, c: ProposalParams, lit: bool) -> list[Proposal]:
    """Centre-surround peaks of ``evidence`` (or of ``value`` for lit reflectors)."""
    out: list[Proposal] = []
    source, field = (LIT_SOURCE, m.value) if lit else (0, m.evidence)
    floor = c.min_lit_response if lit else c.min_response
    means: dict[int, F32] = {}  # one radius's surround is another's centre
    for frac in c.lit_radii if lit else c.blob_radii:
        r = frac * c.work_side
        # Box means (constant time per pixel at any radius) approximate the Gaussians.
        k_in = max(1, int(round(2 * c.centre_sigma * r)) | 1)
        k_out = max(3, int(round(2 * c.surround_sigma * r)) | 1)
        for k in (k_in, k_out):
            if k not in means:
                means[k] = np.asarray(cv2.blur(field, (k, k)), np.float32)
        diff = means[k_in] - means[k_out]
        where = _peaks(diff, max(3, 2 * int(r) + 1), floor)
        if where is None:
            continue
        xs, ys = where.T
        strength = diff[ys, xs]
        for i in np.argsort(-strength)[: c.max_blobs]:
            out.append(Proposal(float(xs[i]), float(ys[i]), r, source, float(strength[i])))
    return out


def _regions(m: Maps, c: ProposalParams) -> list[Proposal]:
    rmin, rmax = (f * c.work_side for f in c.radius_range)
    amin, amax = math.pi * rmin**2, math.pi * (2 * rmax) ** 2
    masks = [(m.chroma >= cr) & (m.redness >= rd) for cr, rd in c.levels] + [m.band]
    out: list[Proposal] = []
    for level, mask in enumerate(masks, start=1):
        # OpenCV's labels without its statistics (ten times the labelling): the areas of
        # all labels, boxes and centroids of the few kept (the very values it gives).
        n, labels = label_regions(np.ascontiguousarray(mask).view(np.uint8))
        # int32, as OpenCV's statistics: numpy's sort may order equal areas by dtype.
        areas = label_areas(labels, n)[1:].astype(np.int32)
        order = [int(i) + 1 for i in np.argsort(-areas) if amin <= areas[i] <= amax]
        for k in order[: c.max_regions]:
            box = label_box(labels, k)
            bw, bh = float(box[2]), float(box[3])
            r = 0.25 * (bw + bh)
            if rmin <= r <= rmax:
                cx, cy = label_centroid(labels, k, box)
                out.append(Proposal(cx, cy, r, level, float(areas[k - 1]) / (bw * bh)))
    return out


def propose(m: Maps, c: ProposalParams = PROPOSAL_PARAMS) -> list[Proposal]:
    """Blob and region proposals of one crop (duplicates are merged later, by shape)."""
    return _blobs(m, c, False) + _blobs(m, c, True) + _regions(m, c)
