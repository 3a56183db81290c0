"""A disc hangs alone; letters come in rows.

Red lettering with closed bowls (О, D, Р, Ø) is the hand-tuned detector's best-known
false ``present``: one letter is a round, filled, red region, and the learned verifiers
describe only the region and its rings, so they can believe it too (generator A's
randomised validation seed 201436: the Ø ending the word "RRBØ", disc score 1.00 and
every verifier above its threshold). What tells a letter is its neighbours: another
region of *the same paint*, about as tall, on the same line, a letter-gap away, or a
row of them (shorter or thinner letters too) a word space away; worn or shaded letters
of that ink are darker, but still farther from the body's colour than from the paint.
A tail disc has no such neighbour (a body stripe is far wider than tall; a buffer or
lamp is not the disc's paint or not beside it at the same height).

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
    gap: float = 0.7
    width_range: tuple[float, float] = (0.35, 1.6)
    min_fill: float = 0.25
    off_line_share: float = 0.25
    body_distance: float = 30.0
    ring: float = 0.25
    ring_share: float = 0.4
    min_side_px: int = 6
    work_height: int = 48
    mark_distance: float = 40.0
    mark_spread: float = 20.0
    row_gap: float = 1.6
    row_members: int = 2
    row_height_ratio: tuple[float, float] = (0.4, 1.45)
    row_width_range: tuple[float, float] = (0.08, 1.6)


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


def _distance2(
    lab: NDArray[np.float32], colour: NDArray[np.float32], p: LetteringParams
) -> NDArray[np.float32]:
    """Squared CIELAB distance (lightness weighted) of each pixel of ``lab`` (h, w, 3)
    to ``colour`` (3,)."""
    diff = (lab - colour) * np.array([p.lightness_weight, 1.0, 1.0], np.float32)
    return np.asarray(np.einsum("ijk,ijk->ij", diff, diff), np.float32)


def _paint_masks(
    lab: NDArray[np.float32],
    paint: NDArray[np.float32],
    body_colour: NDArray[np.float32] | None,
    p: LetteringParams,
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Pixels of ``lab`` (h, w, 3) of the region's ink (within ``paint_distance`` of
    ``paint``, or shaded: see ``shade_distance``) and of about its paint (within
    ``body_distance``), both colourful enough (see the parameters)."""
    distance2 = _distance2(lab, paint, p)
    colourful = _chroma2(lab) >= p.chroma_share**2 * float(_chroma2(paint))
    ink = distance2 <= p.paint_distance**2
    if body_colour is not None:
        shaded = (distance2 <= p.shade_distance**2) & (
            _distance2(lab, body_colour, p) >= p.shade_margin**2 * distance2
        )
        ink |= shaded
    ink &= colourful
    body = (distance2 <= p.body_distance**2) & colourful
    return np.asarray(ink, np.uint8), np.asarray(body, np.uint8)


def _marks(
    lab: NDArray[np.float32],
    body_colour: NDArray[np.float32],
    ink: NDArray[np.uint8],
    p: LetteringParams,
) -> NDArray[np.uint8]:
    """Pixels far from the body's colour that are not of the region's ink (see
    ``mark_distance``)."""
    far = _distance2(lab, body_colour, p) >= p.mark_distance**2
    return np.asarray(far & (ink == 0), np.uint8)


@dataclass(frozen=True)
class _Window:
    """The searched window at its working scale (see ``work_height``).

    ``origin`` is its top-left corner in the image, ``box`` the region in its pixels,
    ``lab`` its CIELAB pixels (h, w, 3), ``body_colour`` the median colour above and below
    the region's line (None when there is no such row), ``ink`` and ``body`` the masks of
    :func:`_paint_masks`."""

    origin: tuple[int, int]
    scale: float
    box: BBox
    lab: NDArray[np.float32]
    body_colour: NDArray[np.float32] | None
    ink: NDArray[np.uint8]
    body: NDArray[np.uint8]

    def to_image(self, found: list[BBox]) -> list[BBox]:
        """Boxes in the window's pixels as image pixels."""
        (x0, y0), f = self.origin, self.scale
        return [
            (x0 + round(x / f), y0 + round(y / f), round(w / f), round(h / f))
            for x, y, w, h in found
        ]


def _window_of(image_bgr: NDArray[np.uint8], box: BBox, p: LetteringParams) -> _Window | None:
    """The window searched around ``box``; None when the body is of about the region's
    paint (see ``off_line_share``) or the box lies outside the image."""
    x0, y0, x1, y1 = _window(image_bgr.shape, box, p.reach)
    crop: NDArray[np.uint8] = image_bgr[y0:y1, x0:x1]
    scale = min(1.0, p.work_height / box[3])
    if scale < 1.0:
        crop = np.asarray(
            cv2.resize(crop, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA), np.uint8
        )
    lab = cv2.cvtColor(crop, cv2.COLOR_BGR2LAB).astype(np.float32)
    x, y, w, h = (box[0] - x0) * scale, (box[1] - y0) * scale, box[2] * scale, box[3] * scale
    local = (int(round(x)), int(round(y)), max(1, int(round(w))), max(1, int(round(h))))
    rows = slice(local[1], local[1] + local[3])
    region = lab[rows, local[0] : local[0] + local[2]]
    if region.size == 0:
        return None
    paint = _paint_of(region, p.colourful)
    line = np.zeros(lab.shape[0], bool)
    line[rows] = True
    off_line = lab[~line].reshape(-1, 3)
    body_colour = np.median(off_line, axis=0).astype(np.float32) if off_line.size else None
    ink, body = _paint_masks(lab, paint, body_colour, p)
    if off_line.size and float(body[~line].mean()) > p.off_line_share:
        return None
    return _Window((x0, y0), scale, local, lab, body_colour, ink, body)


def row_neighbours(
    image_bgr: NDArray[np.uint8], box: BBox, *, params: LetteringParams = LETTERING
) -> list[BBox]:
    """Regions beside the box on its line, as the other letters of its lettering would be:
    of its paint (one a letter gap away, or a row of them a word space away), or a row of
    one other ink (see the parameters).

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
    if min(box[2], box[3]) < params.min_side_px:
        return []
    window = _window_of(image_bgr, box, params)
    if window is None:
        return []
    found = _paint_neighbours(window, params) or _mark_row(window, params)
    return window.to_image(found)


def _components(mask: NDArray[np.uint8]) -> tuple[NDArray[np.int32], list[tuple[BBox, int]]]:
    """Labels of the mask's 8-connected regions and each region's box and area."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    regions = [((int(st[0]), int(st[1]), int(st[2]), int(st[3])), int(st[4])) for st in stats[1:n]]
    return np.asarray(labels, np.int32), regions


def _paint_neighbours(window: _Window, p: LetteringParams) -> list[BBox]:
    """Regions of the box's ink beside it: those a letter gap away, or else a row."""
    box = window.box
    members: list[BBox] = []  # letter-shaped regions of the paint on the box's line
    near: list[BBox] = []  # ... of them, those that make a letter of the box alone
    for other, area in _components(window.ink)[1]:
        if _on_line(box, other, area, p) and _isolated(window.body, other, box, p):
            members.append(other)
            if _is_letter_beside(box, other, area, p):
                near.append(other)
    if near:
        return near
    row = _row(box, members, p)
    return row if len(row) >= p.row_members else []


def _mark_row(window: _Window, p: LetteringParams) -> list[BBox]:
    """A row of marks of one colour through the box's line (see ``mark_distance``)."""
    if window.body_colour is None:
        return []
    marks = _marks(window.lab, window.body_colour, window.ink, p)
    labels, regions = _components(marks)
    members, colours = [], {}
    for k, (other, area) in enumerate(regions, start=1):
        if not (_on_line(window.box, other, area, p) and _isolated(marks, other, window.box, p)):
            continue
        ring = _ring(window.lab.shape[:2], other, window.box, p)
        if ring is None:
            continue
        ya, xa, ring_mask = ring
        around = window.lab[ya : ya + ring_mask.shape[0], xa : xa + ring_mask.shape[1]][ring_mask]
        if float(np.sum((np.median(around, axis=0) - window.body_colour) ** 2)) > p.mark_spread**2:
            continue  # not painted on the body (beside the buffer beam, a lamp's housing)
        members.append(other)
        x, y, w, h = other
        inside = labels[y : y + h, x : x + w] == k
        colours[other] = np.median(window.lab[y : y + h, x : x + w][inside], axis=0)
    row = _row(window.box, members, p)
    if len(row) < p.row_members:
        return []
    first = colours[row[0]]
    spread2 = [float(np.sum((colours[m] - first) ** 2)) for m in row]
    return row if max(spread2) <= p.mark_spread**2 else []


def _gap(box: BBox, other: BBox) -> int:
    """Horizontal pixels between two boxes (negative when they overlap)."""
    return max(other[0] - (box[0] + box[2]), box[0] - (other[0] + other[2]))


def _row(box: BBox, members: list[BBox], p: LetteringParams) -> list[BBox]:
    """The chain of ``members`` reaching the box on either side, each at most
    ``row_gap`` box heights from the previous one (the first from the box)."""
    reach = p.row_gap * box[3]
    chain: list[BBox] = []
    for side in (1, -1):
        edge = box[0] + box[2] if side > 0 else box[0]  # the chain's far end so far
        ahead = sorted(
            (m for m in members if _gap(box, m) >= 0 and (m[0] > box[0]) == (side > 0)),
            key=lambda m: side * m[0],
        )
        for m in ahead:
            near_edge, far_edge = (m[0], m[0] + m[2]) if side > 0 else (m[0] + m[2], m[0])
            if side * (near_edge - edge) > reach:
                break
            chain.append(m)
            edge = far_edge if side * (far_edge - edge) > 0 else edge
    return chain


def _on_line(box: BBox, other: BBox, area: int, p: LetteringParams) -> bool:
    """Whether ``other`` (with ``area`` pixels) is shaped like a letter of a row on the
    box's line (a looser test than :func:`_is_letter_beside`'s)."""
    x, y, w, h = box
    ox, oy, ow, oh = other
    if oh < p.min_side_px or not p.row_height_ratio[0] <= oh / h <= p.row_height_ratio[1]:
        return False
    if not p.row_width_range[0] * oh <= ow <= p.row_width_range[1] * oh:
        return False
    shared = min(y + h, oy + oh) - max(y, oy)
    return area >= p.min_fill * ow * oh and shared >= p.overlap * min(h, oh)


def _ring(
    shape: tuple[int, ...], other: BBox, box: BBox, p: LetteringParams
) -> tuple[int, int, NDArray[np.bool_]] | None:
    """The ring ``ring`` heights wide around ``other`` (window pixels), the region's own
    box left out: its top and left corner and its mask; None when nothing is left."""
    ox, oy, ow, oh = other
    grow = max(1, int(round(p.ring * oh)))
    xa, ya = max(0, ox - grow), max(0, oy - grow)
    xb, yb = min(shape[1], ox + ow + grow), min(shape[0], oy + oh + grow)
    ring = np.ones((yb - ya, xb - xa), bool)
    ring[oy - ya : oy - ya + oh, ox - xa : ox - xa + ow] = False
    bx, by, bw, bh = box
    ring[max(0, by - ya) : max(0, by - ya + bh), max(0, bx - xa) : max(0, bx - xa + bw)] = False
    return (ya, xa, ring) if ring.any() else None


def _isolated(body: NDArray[np.uint8], other: BBox, box: BBox, p: LetteringParams) -> bool:
    """Whether the ring around ``other`` (window pixels) is mostly not of about the paint
    (``body``): a letter is painted on a contrasting body, a body panel between
    corrugations continues into the next one."""
    ring = _ring(body.shape, other, box, p)
    if ring is None:
        return True
    ya, xa, mask = ring
    return (
        float(body[ya : ya + mask.shape[0], xa : xa + mask.shape[1]][mask].mean()) <= p.ring_share
    )


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
    # A component overlapping the box itself (gap < 0) is the region or its own paint.
    return 0 <= _gap(box, other) <= p.gap * h


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
