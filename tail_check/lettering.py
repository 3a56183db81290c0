"""A disc hangs alone; letters come in rows.

Red lettering with closed bowls (О, D, Р, Ø) is the hand-tuned detector's best-known
false ``present``: one letter is a round, filled, red region, and the learned verifiers
describe only the region and its rings, so they can believe it too (generator A's
randomised validation seed 201436: the Ø ending the word "RRBØ", disc score 1.00 and
every verifier above its threshold). What tells a letter is its neighbours: another
region of *the same paint*, about as tall, on the same line, a letter-gap away. A tail
disc has no such neighbour (a body stripe is far wider than tall; a buffer or lamp is
not the disc's paint or not beside it at the same height).

:func:`lettering_reason` looks for such neighbours next to a ``present`` box and gives
the reason to hold it ``uncertain``. It only ever leans towards safety.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = ["LETTERING", "LetteringParams", "lettering_reason", "row_neighbours"]

BBox = tuple[int, int, int, int]


@dataclass(frozen=True)
class LetteringParams:
    """What counts as a row of letters around a disc-shaped region.

    Attributes
    ----------
    reach : the window searched extends this many box heights left and right of the
        box (and ``reach / 4`` above and below).
    paint_distance : a pixel is of the region's paint when its CIELAB colour (OpenCV's
        8-bit scale; lightness weighted by ``lightness_weight``, as shading and dusk
        change it more than the hue) is within this distance of the paint: the median
        colour of the box's most colourful pixels ...
    lightness_weight : weight of the lightness difference in that distance.
    chroma_share : ... and its chroma is at least this share of the paint's (a dark or
        grey surround is never taken for dim red paint).
    colourful : those pixels are the box's share this large of highest chroma (the
        centre of a letter's bowl is the body's paint, a disc's reflector may be white).
    height_ratio : a neighbour's height is within this range of the box's.
    overlap : the neighbour's and the box's vertical extents share at least this
        fraction of the shorter one (same text line).
    gap : at most this many box heights between the box and the neighbour (a letter
        gap; words are a few letter widths apart).
    width_range : a neighbour is as wide as this range of its own heights (a stripe, a
        body panel or a bracket's bar is wider; a post, a pole or a shadow's edge is
        thinner; so are the letters I and 1, which a row has others beside).
    min_fill : a neighbour fills at least this fraction of its bounding box (specks of
        noise do not).
    off_line_share : lettering is painted in a colour other than the body's: when more
        than this share of the window above and below the box's line is within
        ``body_distance`` of the region's paint, the body is of about that paint (a disc
        on a red car, whose panels between the corrugations would look like letters)
        and no row is judged.
    ring, ring_share : a letter is isolated: in the ring this many of its heights wide
        around its box (the region's box left out) at most this share is within
        ``body_distance`` of the paint.
    body_distance : the (looser) colour distance of that test: red-brown panels at dusk
        are near a red disc's colour without being its ink.
    min_side_px : neighbours (and boxes) smaller than this are not judged: at a few
        pixels paint and noise cannot be told apart.
    """

    reach: float = 3.0
    paint_distance: float = 14.0
    lightness_weight: float = 0.5
    chroma_share: float = 0.5
    colourful: float = 0.3
    height_ratio: tuple[float, float] = (0.65, 1.45)
    overlap: float = 0.6
    gap: float = 0.7
    width_range: tuple[float, float] = (0.35, 1.6)
    min_fill: float = 0.25
    off_line_share: float = 0.25
    body_distance: float = 30.0
    ring: float = 0.25
    ring_share: float = 0.4
    min_side_px: int = 6


LETTERING = LetteringParams()


def _window(shape: tuple[int, ...], box: BBox, reach: float) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the searched window, clipped to the image."""
    x, y, w, h = box
    rx, ry = int(math.ceil(reach * h)), int(math.ceil(reach * h / 4))
    return max(0, x - rx), max(0, y - ry), min(shape[1], x + w + rx), min(shape[0], y + h + ry)


_NEUTRAL = 128.0  # OpenCV's 8-bit CIELAB stores a* and b* offset by 128


def _chroma2(lab: NDArray[np.float32]) -> NDArray[np.float32]:
    """Squared chroma of CIELAB pixels (..., 3): no square root, as only order and
    thresholds are asked of it."""
    ab = lab[..., 1:] - np.float32(_NEUTRAL)
    return np.asarray(np.einsum("...k,...k->...", ab, ab), np.float32)


def _paint_of(region: NDArray[np.float32], share: float) -> NDArray[np.float32]:
    """Median CIELAB colour of the ``share`` most colourful pixels of ``region`` (h, w, 3)."""
    pixels = region.reshape(-1, 3)
    chroma2 = _chroma2(pixels)
    keep = chroma2 >= np.quantile(chroma2, 1.0 - share)
    return np.asarray(np.median(pixels[keep], axis=0), np.float32)


def _paint_masks(
    lab: NDArray[np.float32], paint: NDArray[np.float32], p: LetteringParams
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Pixels of ``lab`` (h, w, 3) of the region's ink (within ``paint_distance`` of
    ``paint``) and of about its paint (within ``body_distance``), both colourful enough
    (see the parameters). Squared distances: one pass over the window for both."""
    weight = np.array([p.lightness_weight, 1.0, 1.0], np.float32)
    diff = (lab - paint) * weight
    distance2 = np.einsum("ijk,ijk->ij", diff, diff)
    colourful = _chroma2(lab) >= p.chroma_share**2 * float(_chroma2(paint))
    ink = (distance2 <= p.paint_distance**2) & colourful
    body = (distance2 <= p.body_distance**2) & colourful
    return np.asarray(ink, np.uint8), np.asarray(body, np.uint8)


def row_neighbours(
    image_bgr: NDArray[np.uint8], box: BBox, *, params: LetteringParams = LETTERING
) -> list[BBox]:
    """Regions of the box's paint beside it on the same line, as letters would be.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8, BGR
        The image (not modified).
    box : (x, y, w, h)
        The disc-shaped region, in pixels of ``image_bgr``.
    params : what counts as a neighbouring letter.

    Returns
    -------
    list of (x, y, w, h)
        The neighbours' boxes in image pixels (empty for a region standing alone).
    """
    x, y, w, h = box
    if min(w, h) < params.min_side_px:
        return []
    x0, y0, x1, y1 = _window(image_bgr.shape, box, params.reach)
    crop = image_bgr[y0:y1, x0:x1]
    lab = cv2.cvtColor(crop, cv2.COLOR_BGR2LAB).astype(np.float32)
    local = (x - x0, y - y0, w, h)  # the box in window pixels
    rows = slice(max(0, local[1]), local[1] + h)
    region = lab[rows, max(0, local[0]) : local[0] + w]
    if region.size == 0:
        return []
    paint = _paint_of(region, params.colourful)
    line = np.zeros(lab.shape[0], bool)
    line[rows] = True
    mask, body = _paint_masks(lab, paint, params)
    if (~line).any() and float(body[~line].mean()) > params.off_line_share:
        return []
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    found: list[BBox] = []
    for k in range(1, n):
        bx, by, bw, bh, area = (int(v) for v in stats[k])
        other = (bx + x0, by + y0, bw, bh)
        if _is_letter_beside(box, other, area, params) and _isolated(
            body, (bx, by, bw, bh), local, params
        ):
            found.append(other)
    return found


def _isolated(body: NDArray[np.uint8], other: BBox, box: BBox, p: LetteringParams) -> bool:
    """Whether the ring around ``other`` (window pixels) is mostly not of about the paint
    (``body``), the region's own box left out: a letter is painted on a contrasting body,
    a body panel between corrugations continues into the next one."""
    ox, oy, ow, oh = other
    grow = max(1, int(round(p.ring * oh)))
    wh, ww = body.shape
    xa, ya = max(0, ox - grow), max(0, oy - grow)
    xb, yb = min(ww, ox + ow + grow), min(wh, oy + oh + grow)
    ring = np.ones((yb - ya, xb - xa), bool)
    ring[oy - ya : oy - ya + oh, ox - xa : ox - xa + ow] = False
    bx, by, bw, bh = box
    ring[max(0, by - ya) : max(0, by - ya + bh), max(0, bx - xa) : max(0, bx - xa + bw)] = False
    if not ring.any():
        return True
    return float(body[ya:yb, xa:xb][ring].mean()) <= p.ring_share


def _is_letter_beside(box: BBox, other: BBox, area: int, p: LetteringParams) -> bool:
    """Whether ``other`` (with ``area`` pixels) is a letter-like region beside ``box``."""
    x, y, w, h = box
    ox, oy, ow, oh = other
    if min(ow, oh) < p.min_side_px or not p.height_ratio[0] <= oh / h <= p.height_ratio[1]:
        return False
    if not p.width_range[0] * oh <= ow <= p.width_range[1] * oh or area < p.min_fill * ow * oh:
        return False
    shared = min(y + h, oy + oh) - max(y, oy)
    if shared < p.overlap * min(h, oh):
        return False
    gap = max(ox - (x + w), x - (ox + ow))
    # A component overlapping the box itself (gap < 0) is the region or its own paint.
    return 0 <= gap <= p.gap * h


def lettering_reason(
    image_bgr: NDArray[np.uint8], box: BBox, *, params: LetteringParams = LETTERING
) -> str | None:
    """Why a disc-shaped region may be a letter, or None when it stands alone."""
    beside = row_neighbours(image_bgr, box, params=params)
    if not beside:
        return None
    return (
        f"disc-shaped, but {len(beside)} region(s) of the same paint stand beside it on "
        "the same line, as letters of red lettering do; a person must look"
    )
