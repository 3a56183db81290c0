"""Candidate disc regions: connected regions of the colour mask and their disc score.

Two passes, as in the paper's method: the camera's reference colour finds seed
regions; then, as the paper picks ``c_ref`` inside the disc on the image itself,
each seed's own median colour re-extracts the region around it with the same
``c_Δ``. A real disc then comes out whole (fog, rain and dirt shift its colour
off the camera reference), while a piece of a red body grows into the body. Discs on
a body of their own colour are searched by their rim instead (:mod:`tail_check.rims`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import cv2
import numpy as np
from numpy.typing import NDArray

from .colour import band_mask, occluder_continues, surround_share
from .labels import label_areas, label_box, label_regions
from .profile import CameraProfile
from .shape import CUT_SOLIDITY, RegionShape, cut_members, measure_region, ramp

__all__ = ["DiscCandidate", "disc_score", "find_candidates"]

BBox = tuple[int, int, int, int]
LocalBand = tuple[NDArray[np.bool_], tuple[int, int]]
"""A band mask of a window and the window's top-left corner in the working image."""
MAX_CANDIDATES = 12
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
# Exposure tolerance of the second pass: the seed already fixed the exposure.
_LOCAL_GAIN = (0.75, 1.3)


@dataclass(frozen=True)
class DiscCandidate:
    """One region of disc colour that was checked for disc shape.

    Attributes
    ----------
    bbox : (x, y, w, h)
        Box in pixels of the original image.
    score : float
        Disc-consistency score 0..1 (product of the check memberships).
    diameter : float
        Equivalent-circle diameter as a fraction of ``sqrt(W*H)``.
    shape : RegionShape
        The shape measures the score was built from.
    mean_rgb : tuple of 3 float
        Mean low-passed colour of the region, RGB 0..255.
    surround : float
        Share of a ring around the region covered by the same paint (0 for an
        isolated disc).
    glow : str or None
        Why the region is a lit lamp rather than a disc (:mod:`tail_check.lamps`); such
        a candidate's score is held below the ``present`` threshold.
    """

    bbox: BBox
    score: float
    diameter: float
    shape: RegionShape
    mean_rgb: tuple[float, float, float]
    surround: float
    glow: str | None = None


def disc_score(shape: RegionShape, diameter: float, surround: float, p: CameraProfile) -> float:
    """Disc-consistency score 0..1 of a measured region (product of memberships)."""
    dmin, dmax = p.disc_diameter_range
    fmin, fmax = p.fill_range
    members = (
        ramp(diameter, 0.7 * dmin, dmin, dmax, 1.3 * dmax),
        ramp(shape.fill, fmin - 0.08, fmin, fmax, fmax + 0.03),
        ramp(shape.ellipse_iou, p.min_ellipse_iou - 0.02, p.min_ellipse_iou + 0.02),
        ramp(shape.solidity, 0.6, 0.72),
        ramp(shape.aspect, 0.0, 0.0, 0.8 * p.max_aspect, p.max_aspect),
        ramp(shape.hole_fraction, -1.0, -1.0, 0.12, 0.22),
        ramp(shape.ellipse_residual, -1.0, -1.0, 0.042, 0.065),
        1.0 if shape.large_holes <= 1 and shape.holes <= 2 else 0.0,
        ramp(surround, -1.0, -1.0, 0.3, 0.6),
    )
    # A product, not a mean: one clearly failed check must sink the score.
    whole = float(np.prod(members))
    if shape.cut is None or whole >= p.present_threshold:
        return whole
    # Solidity (stricter: a cut disc is convex), holes and surround still apply.
    kept = (ramp(shape.solidity, *CUT_SOLIDITY), members[5], members[7], members[8])
    return max(whole, float(np.prod(kept + cut_members(shape, diameter, p))))


def _refine(
    seed: NDArray[np.bool_],
    origin: tuple[int, int],
    smooth: NDArray[np.uint8],
    valley_free: NDArray[np.bool_],
    c_delta: float,
) -> tuple[NDArray[np.bool_], tuple[int, int], LocalBand] | None:
    """Re-extract a seed with its own median colour as ``c_ref`` in a window around it.

    Returns the region (cropped to its box), the box origin in the working image, and
    the local band mask of the window with the window's origin, or None when the region
    runs into the window border (it is part of something larger than a disc).
    """
    sx, sy = origin
    sh, sw = seed.shape
    pad = max(3, int(0.9 * max(sh, sw)))
    x0, y0 = max(0, sx - pad), max(0, sy - pad)
    x1, y1 = min(smooth.shape[1], sx + sw + pad), min(smooth.shape[0], sy + sh + pad)
    window = smooth[y0:y1, x0:x1]
    ref_bgr = _median_colour(smooth[sy : sy + sh, sx : sx + sw][seed])
    ref_rgb = (float(ref_bgr[2]), float(ref_bgr[1]), float(ref_bgr[0]))
    if sum(ref_rgb) < 3:
        return None
    local = band_mask(window, ref_rgb, c_delta, gain_range=_LOCAL_GAIN)
    local &= valley_free[y0:y1, x0:x1]
    local |= _place(seed, (sx - x0, sy - y0), local.shape)
    _, labels = label_regions(np.asarray(cv2.erode(local.view(np.uint8), _CROSS), np.uint8))
    seed_labels = labels[sy - y0 : sy - y0 + sh, sx - x0 : sx - x0 + sw][seed]
    seed_labels = seed_labels[seed_labels > 0]
    if seed_labels.size == 0:
        return None
    label = int(np.bincount(seed_labels).argmax())
    x, y, w, h = label_box(labels, label)
    touches = (x == 0 and x0 > 0) or (y == 0 and y0 > 0)
    touches |= x + w >= local.shape[1] and x1 < smooth.shape[1]
    touches |= y + h >= local.shape[0] and y1 < smooth.shape[0]
    if touches:
        return None
    x, y = max(0, x - 1), max(0, y - 1)
    w, h = min(local.shape[1] - x, w + 2), min(local.shape[0] - y, h + 2)
    core = (labels[y : y + h, x : x + w] == label).view(np.uint8)
    region = (cv2.dilate(core, _CROSS) & local[y : y + h, x : x + w].view(np.uint8)).astype(bool)
    return region, (x0 + x, y0 + y), (local, (x0, y0))


def masked_mean(image: NDArray[np.uint8], mask: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Per-channel mean of the masked pixels, ``image[mask].mean(axis=0)`` to the bit.

    Both sum integers exactly in float64 and divide by the count once; numpy's
    reduction over an axis of three is slow, a dot product with the mask is not."""
    weights = mask.reshape(-1).astype(np.float64)
    sums = weights @ image.reshape(-1, image.shape[2]).astype(np.float64)
    return np.asarray(sums / float(np.count_nonzero(mask)), dtype=np.float64)


def _median_colour(pixels: NDArray[np.uint8]) -> NDArray[np.float64]:
    """Per-channel median of (N, 3) pixels, as ``np.median(pixels, axis=0)`` gives it."""
    n = len(pixels)
    half = n // 2
    if n % 2:
        return np.asarray(np.partition(pixels, half, axis=0)[half], dtype=np.float64)
    part = np.partition(pixels, (half - 1, half), axis=0).astype(np.float64)
    return np.asarray((part[half - 1] + part[half]) / 2.0, dtype=np.float64)


def _place(
    part: NDArray[np.bool_], at: tuple[int, int], shape: tuple[int, ...]
) -> NDArray[np.bool_]:
    out = np.zeros(shape[:2], bool)
    out[at[1] : at[1] + part.shape[0], at[0] : at[0] + part.shape[1]] = part
    return out


def _seeds(
    mask: NDArray[np.bool_], p: CameraProfile, work_side: float
) -> list[tuple[BBox, NDArray[np.bool_]]]:
    """Connected regions of ``mask`` of plausible size, largest first, as (box, pixels)."""
    # Label an eroded mask so that 1-2 px bridges (a seam through the rim onto a red
    # body) do not join the disc to its surroundings.
    mask_u8 = mask.view(np.uint8)
    dmin, dmax = p.disc_diameter_range
    area_min = math.pi / 4 * (0.5 * dmin * work_side) ** 2
    area_max = math.pi / 4 * (1.3 * dmax * work_side) ** 2
    if cv2.countNonZero(mask_u8) < area_min:  # no region can be large enough
        return []
    eroded = np.asarray(cv2.erode(mask_u8, _CROSS), np.uint8)
    if cv2.countNonZero(eroded) < area_min:  # the areas below are counted on it
        return []
    (x0, y0), n, labels = _label_crop(eroded)
    all_areas = label_areas(labels, n)
    areas = all_areas[1:]
    keep = np.nonzero((areas >= area_min) & (areas <= area_max))[0] + 1
    keep = keep[np.argsort(-all_areas[keep])][:MAX_CANDIDATES]
    out = []
    for label in keep:
        x, y, w, h = label_box(labels, int(label))
        x, y = max(0, x0 + x - 1), max(0, y0 + y - 1)
        w, h = min(mask.shape[1] - x, w + 2), min(mask.shape[0] - y, h + 2)
        core = (labels[y - y0 : y - y0 + h, x - x0 : x - x0 + w] == label).view(np.uint8)
        region = np.asarray(cv2.dilate(core, _CROSS), np.uint8) & mask_u8[y : y + h, x : x + w]
        out.append(((x, y, w, h), region.astype(bool)))
    return out


def _label_crop(
    mask_u8: NDArray[np.uint8],
) -> tuple[tuple[int, int], int, NDArray[np.uint16]]:
    """:func:`label_regions` of the mask's occupied part: its bounding box with room for
    the seeds' margin, started on even coordinates.

    Grana's algorithm scans 2x2 blocks, so a crop on the same block grid gets the very
    labels of the whole mask, in the same order; the labelling, the area histogram and
    each box search then cost the occupied part only, not the whole working image.
    """
    bx, by, bw, bh = cv2.boundingRect(mask_u8)
    x0, y0 = max(0, bx - 1) & ~1, max(0, by - 1) & ~1
    # Two to the right and below: a seed on the left or top border keeps both extra
    # columns or rows on the far side.
    x1, y1 = min(mask_u8.shape[1], bx + bw + 2), min(mask_u8.shape[0], by + bh + 2)
    n, labels = label_regions(np.ascontiguousarray(mask_u8[y0:y1, x0:x1]))
    return (x0, y0), n, labels


def find_candidates(
    mask: NDArray[np.bool_],
    band: NDArray[np.bool_],
    smooth: NDArray[np.uint8],
    valley_free: NDArray[np.bool_],
    p: CameraProfile,
    *,
    origin: tuple[int, int],
    scale: float,
    work_side: float,
) -> list[DiscCandidate]:
    """Disc candidates in a working-scale search region, best first.

    Parameters
    ----------
    mask : ndarray (h, w) bool
        Camera-band pixels off dark seams (the seeds).
    band : ndarray (h, w) bool
        Camera-band pixels (for the surround check).
    smooth : ndarray (h, w, 3) uint8
        Low-passed BGR working image.
    valley_free : ndarray (h, w) bool
        False on dark seams.
    origin, scale
        The region's top-left corner in the original image and the working scale
        (working pixels per original pixel), to report boxes in original pixels.
    work_side : float
        ``sqrt(w*h)`` of the whole working image, for relative sizes.
    """
    found: list[DiscCandidate] = []
    for (x, y, _w, _h), seed in _seeds(mask, p, work_side):
        refined = _refine(seed, (x, y), smooth, valley_free, p.c_delta)
        if refined is None:
            continue
        region, (rx, ry), local_band = refined
        shape = measure_region(region)
        if shape is None:
            continue
        rh, rw = region.shape
        diameter = math.sqrt(4.0 * shape.area / math.pi) / work_side
        mean_bgr = masked_mean(smooth[ry : ry + rh, rx : rx + rw], region)
        surround = surround_share(
            band, smooth[..., 2], (rx, ry, rw, rh), float(mean_bgr[2]), extra=local_band
        )
        bbox = (
            origin[0] + int(round(rx / scale)),
            origin[1] + int(round(ry / scale)),
            max(1, int(round(rw / scale))),
            max(1, int(round(rh / scale))),
        )
        found.append(
            DiscCandidate(
                bbox=bbox,
                score=_checked_score(shape, diameter, surround, smooth, (rx, ry), p),
                diameter=diameter,
                shape=shape,
                mean_rgb=(float(mean_bgr[2]), float(mean_bgr[1]), float(mean_bgr[0])),
                surround=surround,
            )
        )
    found.sort(key=lambda c: -c.score)
    return _distinct(found)


def _checked_score(
    shape: RegionShape,
    diameter: float,
    surround: float,
    smooth: NDArray[np.uint8],
    at: tuple[int, int],
    p: CameraProfile,
) -> float:
    """:func:`disc_score`, with a cut-disc fit trusted for ``present`` only where a real
    occluder (a pole, a post) goes on past the disc along the cut."""
    score = disc_score(shape, diameter, surround, p)
    if score >= p.present_threshold and shape.cut is not None:
        whole = disc_score(replace(shape, cut=None), diameter, surround, p)
        if whole < p.present_threshold:
            score = max(whole, score * occluder_continues(smooth, shape.cut, at))
    return score


def _distinct(cands: list[DiscCandidate]) -> list[DiscCandidate]:
    """Drop candidates whose box centre lies in a better candidate's box (same disc)."""
    out: list[DiscCandidate] = []
    for c in cands:
        cx, cy = c.bbox[0] + c.bbox[2] / 2, c.bbox[1] + c.bbox[3] / 2
        if not any(
            o.bbox[0] <= cx <= o.bbox[0] + o.bbox[2] and o.bbox[1] <= cy <= o.bbox[1] + o.bbox[3]
            for o in out
        ):
            out.append(c)
    return out
