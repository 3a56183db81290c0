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

import cv2
import numpy as np
from numpy.typing import NDArray

from ._lettering_ink import LETTERING, BBox, LetteringParams, Window, marks_of, window_of

__all__ = ["LETTERING", "LetteringParams", "lettering_reason", "row_neighbours"]


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
    window = window_of(image_bgr, box, params)
    if window is None:
        return []
    found = _paint_neighbours(window, params) or _mark_row(window, params)
    return window.to_image(found)


def _components(mask: NDArray[np.uint8]) -> tuple[NDArray[np.int32], list[tuple[BBox, int]]]:
    """Labels of the mask's 8-connected regions and each region's box and area."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    regions = [((int(st[0]), int(st[1]), int(st[2]), int(st[3])), int(st[4])) for st in stats[1:n]]
    return np.asarray(labels, np.int32), regions


def _paint_neighbours(window: Window, p: LetteringParams) -> list[BBox]:
    """Regions of the box's ink beside it: those a letter gap away, or else a row."""
    box = window.box
    members: list[BBox] = []  # letter-shaped regions of the paint on the box's line
    near: list[BBox] = []  # ... of them, those that make a letter of the box alone
    for other, area in _components(window.ink)[1]:
        if _row_member(box, other, area, p) and _isolated(
            window.body, _ring(window.ink.shape, other, box, p), p
        ):
            members.append(other)
            if _is_letter_beside(box, other, area, p) or _is_stroke_beside(box, other, area, p):
                near.append(other)
    if near:
        return near
    row = _row(box, members, p)
    return row if len(row) >= p.row_members else []


def _mark_row(window: Window, p: LetteringParams) -> list[BBox]:
    """A row of marks of one colour through the box's line (see ``mark_distance``)."""
    marks, body_colour = marks_of(window, p), window.body_colour
    if marks is None or body_colour is None:  # both or neither: no rows off the line
        return []
    labels, regions = _components(marks)
    members, colours = [], {}
    for k, (other, area) in enumerate(regions, start=1):
        if not _on_line(window.box, other, area, p):
            continue
        ring = _ring(marks.shape, other, window.box, p)
        if ring is None or not _isolated(marks, ring, p):
            continue
        around = window.lab[ring[0]][ring[1]]
        if float(np.sum((np.median(around, axis=0) - body_colour) ** 2)) > p.mark_spread**2:
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
    h = box[3]
    ow, oh = other[2], other[3]
    if oh < p.min_side_px or not p.row_height_ratio[0] <= oh / h <= p.row_height_ratio[1]:
        return False
    if not p.row_width_range[0] * oh <= ow <= p.row_width_range[1] * oh:
        return False
    return area >= p.min_fill * ow * oh and _same_line(box, other, p)


def _same_line(box: BBox, other: BBox, p: LetteringParams) -> bool:
    """Whether the two vertical extents share ``overlap`` of the shorter one."""
    shared = min(box[1] + box[3], other[1] + other[3]) - max(box[1], other[1])
    return shared >= p.overlap * min(box[3], other[3])


def _row_member(box: BBox, other: BBox, area: int, p: LetteringParams) -> bool:
    """A letter of a row on the box's line (:func:`_on_line`) or a dash between two."""
    return _on_line(box, other, area, p) or _is_dash(box, other, area, p)


def _is_dash(box: BBox, other: BBox, area: int, p: LetteringParams) -> bool:
    """Whether ``other`` is a hyphen or dash on the box's line ("1-0", "-0-"): wider than
    tall, solid, a fraction of the box's height, about its middle (see ``dash_height``)."""
    x, y, w, h = box
    ox, oy, ow, oh = other
    if oh < 2 or ow <= oh or not p.dash_height[0] <= oh / h <= p.dash_height[1]:
        return False
    middle = abs((oy + oh / 2) - (y + h / 2)) <= p.dash_offset * h
    return (
        middle
        and p.dash_width[0] * h <= ow <= p.dash_width[1] * h
        and area >= p.dash_fill * ow * oh
    )


def _is_stroke_beside(box: BBox, other: BBox, area: int, p: LetteringParams) -> bool:
    """Whether ``other`` is a stroke (I, 1, l) a letter gap from the box that starts and
    ends where the box does, as letters of one line do (a post or a bracket's bar runs
    past the disc); see ``stroke_edges``."""
    x, y, w, h = box
    ox, oy, ow, oh = other
    if oh < p.min_side_px or not p.row_width_range[0] * oh <= ow < p.width_range[0] * oh:
        return False
    if abs(oy - y) > p.stroke_edges * h or abs(oy + oh - (y + h)) > p.stroke_edges * h:
        return False
    return area >= p.stroke_fill * ow * oh and 0 <= _gap(box, other) <= p.gap * h


Ring = tuple[tuple[slice, slice], NDArray[np.bool_]]
"""A ring around a region: the window's rows and columns it spans, and its mask there."""


def _ring(shape: tuple[int, ...], other: BBox, box: BBox, p: LetteringParams) -> Ring | None:
    """The ring ``ring`` heights wide around ``other`` (window pixels), the region's own
    box left out; None when nothing is left."""
    ox, oy, ow, oh = other
    grow = max(1, int(round(p.ring * oh)))
    xa, ya = max(0, ox - grow), max(0, oy - grow)
    xb, yb = min(shape[1], ox + ow + grow), min(shape[0], oy + oh + grow)
    ring = np.ones((yb - ya, xb - xa), bool)
    ring[oy - ya : oy - ya + oh, ox - xa : ox - xa + ow] = False
    bx, by, bw, bh = box
    ring[max(0, by - ya) : max(0, by - ya + bh), max(0, bx - xa) : max(0, bx - xa + bw)] = False
    return ((slice(ya, yb), slice(xa, xb)), ring) if ring.any() else None


def _isolated(body: NDArray[np.uint8], ring: Ring | None, p: LetteringParams) -> bool:
    """Whether the ring around a region (window pixels) is mostly not of about the paint
    (``body``): a letter is painted on a contrasting body, a body panel between
    corrugations continues into the next one."""
    if ring is None:
        return True
    return float(body[ring[0]][ring[1]].mean()) <= p.ring_share


def _is_letter_beside(box: BBox, other: BBox, area: int, p: LetteringParams) -> bool:
    """Whether ``other`` (with ``area`` pixels) is a letter-like region beside ``box``."""
    h = box[3]
    ow, oh = other[2], other[3]
    if min(ow, oh) < p.min_side_px or not p.height_ratio[0] <= oh / h <= p.height_ratio[1]:
        return False
    if not p.width_range[0] * oh <= ow <= p.width_range[1] * oh or area < p.min_fill * ow * oh:
        return False
    if not _same_line(box, other, p):
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
