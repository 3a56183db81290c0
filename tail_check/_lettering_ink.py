"""The window around a disc-shaped region and the inks in it, for :mod:`.lettering`.

The window is searched at a working scale; in it, the region's ink (its paint, or that
paint shaded or worn), about its paint (the body of a car of nearly the disc's colour),
and marks of other inks on the body. Every threshold is a :class:`LetteringParams`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from .pixels import clip_window, median_u8

__all__ = [
    "LETTERING",
    "BBox",
    "LetteringParams",
    "Window",
    "chroma2",
    "lab_distance",
    "marks_of",
    "window_of",
]

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
    shade_distance, shade_margin : worn or shaded letters of the same ink are darker
        (0.7 of the brightness is a CIELAB distance of about 27): a pixel within
        ``shade_distance`` of the paint is of its ink too when it is at least
        ``shade_margin`` times as far from the body's colour (the median of the window
        above and below the box's line), so a body of nearly the paint never is.
    chroma_share : ... and its chroma is at least this share of the paint's (a dark or
        grey surround is never taken for dim red paint).
    colourful : those pixels are the box's share this large of highest chroma (the
        centre of a letter's bowl is the body's paint, a disc's reflector may be white).
    height_ratio : a neighbour's height is within this range of the box's.
    overlap : the neighbour's and the box's vertical extents share at least this
        fraction of the shorter one (same text line).
    gap : at most this many box heights between the box and a lone neighbour (letters of
        stencilled car lettering stand up to about a letter height apart; the
        independent trial's "0  1" stood 1.2 apart).
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
    dash_height, dash_width, dash_offset, dash_fill : a hyphen or dash is a member of a
        row too ("1-0", "-0-"): a region this fraction of the box's height tall, this
        many box heights wide (and wider than tall), its centre at most ``dash_offset``
        box heights from the box's, filling at least ``dash_fill`` of its bounding box.
    stroke_edges, stroke_fill : a lone stroke (I, 1) narrower than ``width_range`` a
        letter gap away counts as a neighbour when its top and bottom are within
        ``stroke_edges`` box heights of the box's and it fills ``stroke_fill`` of its
        bounding box ("I0", "01").
    work_height : the window is judged at a scale where the box is at most this many
        pixels tall (letters keep their shapes; a 1080p close-up's window would be a
        quarter of a million pixels), the pixel sizes above at that scale.
    mark_distance : lettering of *another* ink with the region among it (a red Р in a
        yellow ФОРМА): a pixel is a mark when it is this far from the body's colour and
        not of the region's ink; a row of ``row_members`` marks of one colour (each
        within ``mark_spread`` of the nearest's median colour) counts as lettering, a
        lone mark does not (a lamp or a buffer beside a disc).
    mark_spread : see ``mark_distance``.
    row_gap : a *row* of letters may stand farther off: a chain of letter-like regions
        on the box's line, each at most this many box heights from the previous one
        (the first from the box), counts when it holds ``row_members`` regions or more
        (words are a space apart; a lone region that far off may be anything).
    row_members : the fewest regions of such a row.
    row_height_ratio : a row's regions may be shorter than a lone neighbour (smaller
        lettering beside a big digit, lower-case letters) ...
    row_width_range : ... and narrower (the strokes I, 1, l), in their own heights.
    """

    reach: float = 3.0
    paint_distance: float = 14.0
    lightness_weight: float = 0.5
    shade_distance: float = 30.0
    shade_margin: float = 2.0
    chroma_share: float = 0.5
    colourful: float = 0.3
    height_ratio: tuple[float, float] = (0.65, 1.45)
    overlap: float = 0.6
    gap: float = 1.3
    width_range: tuple[float, float] = (0.35, 1.6)
    min_fill: float = 0.25
    off_line_share: float = 0.25
    body_distance: float = 30.0
    ring: float = 0.25
    ring_share: float = 0.4
    min_side_px: int = 6
    work_height: int = 48
    dash_height: tuple[float, float] = (0.12, 0.4)
    dash_width: tuple[float, float] = (0.25, 1.0)
    dash_offset: float = 0.25
    dash_fill: float = 0.6
    stroke_edges: float = 0.15
    stroke_fill: float = 0.5
    mark_distance: float = 40.0
    mark_spread: float = 20.0
    row_gap: float = 1.6
    row_members: int = 2
    row_height_ratio: tuple[float, float] = (0.4, 1.45)
    row_width_range: tuple[float, float] = (0.08, 1.6)


LETTERING = LetteringParams()


def _window(shape: tuple[int, ...], box: BBox, reach: float) -> tuple[int, int, int, int] | None:
    """(x0, y0, x1, y1) of the searched window clipped to the image, or None outside it."""
    x, y, w, h = box
    rx, ry = int(math.ceil(reach * h)), int(math.ceil(reach * h / 4))
    return clip_window(shape, x - rx, y - ry, x + w + rx, y + h + ry)


_NEUTRAL = 128.0  # OpenCV's 8-bit CIELAB stores a* and b* offset by 128


def chroma2(lab: NDArray[np.float32]) -> NDArray[np.float32]:
    """Squared chroma of CIELAB pixels (..., 3): no square root, as only order and
    thresholds are asked of it. Plane by plane (numpy's einsum over a length-3 axis takes
    five times as long, for the very same float32 sums)."""
    a = lab[..., 1] - np.float32(_NEUTRAL)
    b = lab[..., 2] - np.float32(_NEUTRAL)
    return np.asarray(a * a + b * b, np.float32)


def _paint_of(region: NDArray[np.float32], share: float) -> NDArray[np.float32]:
    """Median CIELAB colour of the ``share`` most colourful pixels of ``region`` (h, w, 3)."""
    pixels = region.reshape(-1, 3)
    colour2 = chroma2(pixels)
    keep = colour2 >= np.quantile(colour2, 1.0 - share)
    return np.asarray(np.median(pixels[keep], axis=0), np.float32)


def lab_distance(
    colours: NDArray[np.float32], to: NDArray[np.float32], lightness_weight: float
) -> NDArray[np.float32]:
    """CIELAB distance (OpenCV's 8-bit scale, lightness weighted by ``lightness_weight``)
    of colours (..., 3) to one colour (3,): the housing's ring and the pair's twin are
    measured against the region's field with it."""
    diff = (colours - to) * np.array([lightness_weight, 1.0, 1.0], np.float32)
    return np.asarray(np.sqrt(np.einsum("...k,...k->...", diff, diff)), np.float32)


def _distance2(
    lab: NDArray[np.float32], colour: NDArray[np.float32], p: LetteringParams
) -> NDArray[np.float32]:
    """Squared CIELAB distance (lightness weighted) of each pixel of ``lab`` (h, w, 3)
    to ``colour`` (3,): on contiguous planes, the same float32 sums as an einsum over
    the channels in a third of its time."""
    lightness, a, b = (np.asarray(plane, np.float32) for plane in cv2.split(lab))
    dl = (lightness - colour[0]) * np.float32(p.lightness_weight)
    da, db = a - colour[1], b - colour[2]
    return np.asarray(dl * dl + da * da + db * db, np.float32)


def _paint_masks(
    lab: NDArray[np.float32],
    paint: NDArray[np.float32],
    to_body2: NDArray[np.float32] | None,
    p: LetteringParams,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Pixels of ``lab`` (h, w, 3) of the region's ink (within ``paint_distance`` of
    ``paint``, or shaded: see ``shade_distance``; ``to_body2`` is each pixel's squared
    distance to the body's colour) and of about its paint (within ``body_distance``),
    both colourful enough (see the parameters)."""
    distance2 = _distance2(lab, paint, p)
    colourful = chroma2(lab) >= p.chroma_share**2 * float(chroma2(paint))
    ink = distance2 <= p.paint_distance**2
    if to_body2 is not None:
        ink |= (distance2 <= p.shade_distance**2) & (to_body2 >= p.shade_margin**2 * distance2)
    ink &= colourful
    body = (distance2 <= p.body_distance**2) & colourful
    return np.asarray(ink, np.uint8), np.asarray(body, np.uint8)


def marks_of(window: Window, p: LetteringParams) -> NDArray[np.uint8] | None:
    """The window's pixels far from the body's colour that are not of the region's ink
    (see ``mark_distance``); None when the window has no body colour."""
    if window.to_body2 is None:
        return None
    return np.asarray((window.to_body2 >= p.mark_distance**2) & (window.ink == 0), np.uint8)


@dataclass(frozen=True)
class Window:
    """The searched window at its working scale (see ``work_height``).

    ``origin`` is its top-left corner in the image, ``box`` the region in its pixels,
    ``lab`` its CIELAB pixels (h, w, 3), ``body_colour`` the median colour above and below
    the region's line (None when there is no such row) and ``to_body2`` each pixel's
    squared distance to it, ``ink`` and ``body`` the masks of :func:`_paint_masks`."""

    origin: tuple[int, int]
    scale: float
    box: BBox
    lab: NDArray[np.float32]
    body_colour: NDArray[np.float32] | None
    to_body2: NDArray[np.float32] | None
    ink: NDArray[np.uint8]
    body: NDArray[np.uint8]

    def to_image(self, found: list[BBox]) -> list[BBox]:
        """Boxes in the window's pixels as image pixels."""
        (x0, y0), f = self.origin, self.scale
        return [
            (x0 + round(x / f), y0 + round(y / f), round(w / f), round(h / f))
            for x, y, w, h in found
        ]


def _median_colour(pixels: NDArray[np.uint8]) -> NDArray[np.float32]:
    """``np.median(pixels.astype(np.float32), axis=0)`` of uint8 pixels (n, 3), bit for bit,
    from each channel's histogram instead of a partition."""
    return np.array([median_u8(pixels[:, k]) for k in range(3)], np.float32)


def window_of(image_bgr: NDArray[np.uint8], box: BBox, p: LetteringParams) -> Window | None:
    """The window searched around ``box``; None when the body is of about the region's
    paint (see ``off_line_share``) or the box lies outside the image."""
    window = _window(image_bgr.shape, box, p.reach)
    if window is None or box[3] < 1:
        return None
    x0, y0, x1, y1 = window
    crop: NDArray[np.uint8] = image_bgr[y0:y1, x0:x1]
    scale = min(1.0, p.work_height / box[3])
    if min(crop.shape[:2]) * scale < 1.0:
        return None  # the working scale leaves no pixel of the window
    if scale < 1.0:
        crop = np.asarray(
            cv2.resize(crop, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA), np.uint8
        )
    lab_u8 = np.asarray(cv2.cvtColor(crop, cv2.COLOR_BGR2LAB), np.uint8)
    lab = lab_u8.astype(np.float32)
    x, y, w, h = (box[0] - x0) * scale, (box[1] - y0) * scale, box[2] * scale, box[3] * scale
    local = (int(round(x)), int(round(y)), max(1, int(round(w))), max(1, int(round(h))))
    rows = slice(local[1], local[1] + local[3])
    region = lab[rows, local[0] : local[0] + local[2]]
    if region.size == 0:
        return None
    paint = _paint_of(region, p.colourful)
    line = np.zeros(lab.shape[0], bool)
    line[rows] = True
    off_line = lab_u8[~line].reshape(-1, 3)
    body_colour = _median_colour(off_line) if off_line.size else None
    to_body2 = None if body_colour is None else _distance2(lab, body_colour, p)
    ink, body = _paint_masks(lab, paint, to_body2, p)
    if off_line.size and float(body[~line].mean()) > p.off_line_share:
        return None
    return Window((x0, y0), scale, local, lab, body_colour, to_body2, ink, body)
