"""A tail disc carries one reflector; a roundel carries lettering.

A red roundel with white letters inside ("RD", a railway's initials, in generator C's
scenes; the independent trial's roundels) is round, filled and red, the
hand-tuned detector's idea of a disc, and the learned verifiers, which describe a region
by its colour statistics and rings, believed one of them too (generator C's seed
370239, every verifier above its threshold). What tells it is what lies *inside* the
field: a tail disc's field holds one reflector, a compact blob at its centre (a
brighter red by day, near white when a headlight lights it); a roundel's holds marks of
a light ink that are several, or off its centre, or not blob-shaped (the strokes of a
letter, a digit, an arrow).

:func:`emblem_reason` looks for such marks inside a ``present`` box and gives the reason
to hold it ``uncertain``. It only ever leans towards safety. Measured on the 390
hand-tuned ``present`` on true discs of generators A, B and C (340000-340119 each, A's
randomised mode 340000-340119 and 201000-202399, B 201000-201199): it holds 1 (A:201720,
a snow streak across the reflector); of the 11 ``present`` there without a disc it holds
the one roundel (C:340119). On the independent trial's fresh scenes (trial 3, seeds
980000-980599, used for nothing before) the service's false ``present`` on roundels with
letters fell from 11 of 90 to 0, and no ``present`` on a true disc was held.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from ._lettering_ink import BBox, chroma2
from .pixels import clip_window

__all__ = ["EMBLEM", "EmblemParams", "emblem_marks", "emblem_reason"]


@dataclass(frozen=True)
class EmblemParams:
    """What counts as lettering inside a disc-shaped region.

    Attributes
    ----------
    work_height : the box is judged at a scale where it is at most this many pixels
        tall (a letter's strokes stay two or more pixels wide; a 1080p close-up is not
        judged on a hundred thousand pixels).
    min_side_px : boxes smaller than this are not judged: at a few pixels a letter and a
        reflector cannot be told apart.
    field : the field searched is the ellipse inscribed in the box, shrunk to this
        fraction of its radii (a disc's rim and the surround at the box's corners are
        left out).
    colourful : the paint is the median CIELAB colour (OpenCV's 8-bit scale) of this
        share of the field's most colourful pixels.
    lighter : a pixel is of a light ink when its lightness is at least this much above
        the paint's ...
    chroma_share : ... and its chroma at most this share of the paint's (a reflector by
        day is a brighter red, as colourful as the field, and is no mark at all).
    close_px : the light pixels are closed (a morphological closing, this many working
        pixels across) before they are split into marks.
    min_height : a mark is at least this fraction of the box's height tall (snowflakes,
        rain drops and JPEG speckle are smaller; so is a lit reflector seen small, which
        is one compact blob anyway).
    centre_offset : a reflector-like mark's centre lies within this fraction of the
        box's half-height of the box's centre ...
    blob_aspect, blob_solidity : ... it is about as wide as tall (its width over height
        in this range) and fills at least ``blob_solidity`` of its convex hull (a round or
        square blob nearly all of it; a letter's strokes leave the hull's corners and bays
        empty). Measured after the closing: drawn M, 5, H, T, X, R and D 0.54-0.72 in
        roundels 40-140 pixels across; the reflectors of generator A's and B's discs
        that came closest 0.81-0.89 (small, noisy or streaked by rain), drawn ones 0.91
        and more. Bold letters fill their hulls nearly as well (0.72-0.91) ...
    blob_iou : ... so a reflector-like mark also overlaps the ellipse inscribed in its
        bounding box by at least this much (intersection over union): a bold 5, R, P, W,
        3, M or O 0.61-0.78, 8 and S 0.74-0.82; the closest reflectors above 0.81, drawn
        ones 0.83 and more.
    """

    work_height: int = 48
    min_side_px: int = 10
    field: float = 0.8
    colourful: float = 0.3
    lighter: float = 45.0
    chroma_share: float = 0.5
    close_px: int = 3
    min_height: float = 0.2
    centre_offset: float = 0.3
    blob_aspect: tuple[float, float] = (0.6, 1.6)
    blob_solidity: float = 0.78
    blob_iou: float = 0.8


EMBLEM = EmblemParams()

Mark = tuple[float, float, float, float, float, float]
"""A mark inside the field: see :func:`emblem_marks`."""


def _field_lab(
    image_bgr: NDArray[np.uint8], box: BBox, p: EmblemParams
) -> tuple[NDArray[np.float32], NDArray[np.bool_]] | None:
    """The box's CIELAB pixels at the working scale and the mask of its field."""
    x, y, w, h = box
    window = clip_window(image_bgr.shape, x, y, x + w, y + h)
    if window is None:
        return None
    x0, y0, x1, y1 = window
    crop = image_bgr[y0:y1, x0:x1]
    if crop.shape[0] < p.min_side_px or crop.shape[1] < p.min_side_px:
        return None
    scale = min(1.0, p.work_height / crop.shape[0])
    if scale < 1.0:
        crop = np.asarray(
            cv2.resize(crop, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA), np.uint8
        )
    lab = cv2.cvtColor(np.ascontiguousarray(crop), cv2.COLOR_BGR2LAB).astype(np.float32)
    rows, cols = lab.shape[:2]
    # The ellipse of the whole box (a box clipped by the image edge keeps its own centre).
    cy = ((y + h / 2) - y0) * scale - 0.5
    cx = ((x + w / 2) - x0) * scale - 0.5
    ry, rx = p.field * h * scale / 2, p.field * w * scale / 2
    yy, xx = np.mgrid[0:rows, 0:cols]
    inside = ((yy - cy) / ry) ** 2 + ((xx - cx) / rx) ** 2 <= 1.0
    return lab, np.asarray(inside, np.bool_)


def emblem_marks(
    image_bgr: NDArray[np.uint8], box: BBox, *, params: EmblemParams = EMBLEM
) -> list[Mark]:
    """The marks of a light ink inside the region's field.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8, BGR
        The image (not modified).
    box : (x, y, w, h)
        The disc-shaped region, in pixels of ``image_bgr``.
    params : what counts as a mark.

    Returns
    -------
    list of (dx, dy, height, aspect, solidity, ellipse_iou)
        Each mark's centre relative to the box's centre and its height, in box
        half-heights and box heights, its width over its height, the share of its
        convex hull it fills and its overlap with the ellipse inscribed in its bounding
        box (empty when the box is too small to judge).
    """
    found = _field_lab(image_bgr, box, params)
    if found is None:
        return []
    lab, inside = found
    colour2 = chroma2(lab)
    field2 = colour2[inside]
    if field2.size == 0:
        return []
    keep = field2 >= np.quantile(field2, 1.0 - params.colourful)
    paint_l = float(np.median(lab[..., 0][inside][keep]))
    paint_c2 = float(np.median(field2[keep]))
    light = (
        inside
        & (lab[..., 0] >= paint_l + params.lighter)
        & (colour2 <= params.chroma_share**2 * paint_c2)
    )
    marked = np.asarray(light, np.uint8)
    if params.close_px > 1:
        # Noise and rain streaks pit a small reflector's outline; a letter's bays are wider.
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (params.close_px,) * 2)
        marked = np.asarray(cv2.morphologyEx(marked, cv2.MORPH_CLOSE, kernel), np.uint8)
    n, labels, stats, centroids = cv2.connectedComponentsWithStats(marked, connectivity=8)
    rows, cols = lab.shape[:2]
    half = rows / 2
    marks = []
    for i in range(1, n):
        x, y, w, h, area = (int(v) for v in stats[i, :5])
        if h < params.min_height * rows:
            continue
        dx = (float(centroids[i, 0]) - (cols - 1) / 2) / half
        dy = (float(centroids[i, 1]) - (rows - 1) / 2) / half
        mark = labels[y : y + h, x : x + w] == i  # its own box: the shape measures are local
        marks.append((dx, dy, h / rows, w / h, _solidity(mark, area), _ellipse_iou(mark)))
    return marks


def _solidity(mask: NDArray[np.bool_], area: int) -> float:
    """Share of its convex hull a region (``mask``, ``area`` pixels) fills."""
    points = cv2.findNonZero(np.asarray(mask, np.uint8))
    # The hull of pixel centres misses half a pixel all round: measure it on corners.
    corners = points.reshape(-1, 1, 2) + np.array([[[0, 0], [1, 0], [0, 1], [1, 1]]])
    hull = cv2.convexHull(corners.reshape(-1, 2).astype(np.int32))
    return min(1.0, area / max(1.0, float(cv2.contourArea(hull))))


def _ellipse_iou(mask: NDArray[np.bool_]) -> float:
    """Intersection over union of a region (``mask``) and the ellipse inscribed in its
    bounding box."""
    ys, xs = np.nonzero(mask)
    region = mask[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]
    h, w = region.shape
    yy, xx = np.mgrid[0:h, 0:w]
    ellipse = ((yy + 0.5 - h / 2) / (h / 2)) ** 2 + ((xx + 0.5 - w / 2) / (w / 2)) ** 2 <= 1.0
    return float((region & ellipse).sum() / max(1, int((region | ellipse).sum())))


def _reflector_like(mark: Mark, p: EmblemParams) -> bool:
    dx, dy, _, aspect, solidity, iou = mark
    centred = math.hypot(dx, dy) <= p.centre_offset
    blob = solidity >= p.blob_solidity and iou >= p.blob_iou
    return centred and p.blob_aspect[0] <= aspect <= p.blob_aspect[1] and blob


def emblem_reason(
    image_bgr: NDArray[np.uint8], box: BBox, *, params: EmblemParams = EMBLEM
) -> str | None:
    """Why the region is a roundel with lettering rather than a disc, or None when its
    field holds nothing but (at most) one reflector (see :func:`emblem_marks`)."""
    marks = emblem_marks(image_bgr, box, params=params)
    if not marks or (len(marks) == 1 and _reflector_like(marks[0], params)):
        return None
    what = f"{len(marks)} marks" if len(marks) > 1 else "a mark that is no reflector"
    return (
        f"{what} of a light ink inside the disc-shaped region (lettering on a roundel; a "
        "tail disc holds one reflector at its centre); a person must look"
    )
