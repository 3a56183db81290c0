"""Drawn trackside scenes for the tail-check tests: a car's end wall, a tail disc on its
bracket, and the camera's noise and blur."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

GREY = (128, 124, 120)  # BGR body paint
SIGNAL_RED = (40, 30, 200)
WHITE = (235, 235, 235)
BEAM_TOP = 440  # the buffer beam's top row in end_wall()
BBox = tuple[int, int, int, int]


def end_wall(paint: tuple[int, int, int] = GREY) -> NDArray[np.uint8]:
    """A car end (800x600) with corrugations, a dark buffer beam and ballast."""
    image = np.full((600, 800, 3), paint, np.uint8)
    shade = tuple(int(v * 0.75) for v in paint)
    for x in range(30, 800, 50):
        cv2.line(image, (x, 0), (x, BEAM_TOP), shade, 3)
    image[BEAM_TOP : BEAM_TOP + 50] = (30, 30, 30)
    image[BEAM_TOP + 50 :] = (90, 100, 105)
    return image


def noisy(image: NDArray[np.uint8], seed: int = 0) -> NDArray[np.uint8]:
    """The scene as a camera gives it: sensor noise, then a slight blur."""
    noise = np.random.default_rng(seed).normal(0.0, 4.0, image.shape)
    blurred = cv2.GaussianBlur(np.clip(image + noise, 0, 255).astype(np.uint8), (0, 0), 0.8)
    return np.asarray(blurred, np.uint8)


def tail_disc(
    image: NDArray[np.uint8], centre: tuple[int, int], r: int, reflector: tuple[int, int, int]
) -> BBox:
    """A tail disc on its bracket: a dark rim, the red field, a reflector at its centre."""
    cx, cy = centre
    cv2.rectangle(image, (cx - 4, cy), (cx + 4, BEAM_TOP), (40, 40, 40), -1)
    cv2.circle(image, centre, r + 3, (25, 25, 25), -1, cv2.LINE_AA)
    cv2.circle(image, centre, r, SIGNAL_RED, -1, cv2.LINE_AA)
    cv2.circle(image, centre, max(3, r // 3), reflector, -1, cv2.LINE_AA)
    return cx - r, cy - r, 2 * r, 2 * r


LENS_RED = (30, 25, 150)  # BGR: an unlit lens, a deeper red than the paint of a disc


def roundel(
    image: NDArray[np.uint8], centre: tuple[int, int], r: int, text: str, *, bold: bool = False
) -> BBox:
    """A red roundel with white lettering (bold: strokes a fifth of the radius wide)."""
    cv2.circle(image, centre, r, SIGNAL_RED, -1, cv2.LINE_AA)
    font = cv2.FONT_HERSHEY_DUPLEX if bold else cv2.FONT_HERSHEY_SIMPLEX
    scale, stroke = (r / 26.0, max(3, r // 5)) if bold else (r / 28.0, max(2, r // 9))
    (tw, th), _ = cv2.getTextSize(text, font, scale, stroke)
    origin = (centre[0] - tw // 2, centre[1] + th // 2)
    cv2.putText(image, text, origin, font, scale, WHITE, stroke, cv2.LINE_AA)
    return centre[0] - r, centre[1] - r, 2 * r, 2 * r


def arrow_roundel(image: NDArray[np.uint8], centre: tuple[int, int], r: int) -> BBox:
    cv2.circle(image, centre, r, SIGNAL_RED, -1, cv2.LINE_AA)
    cx, cy = centre
    tip, tail = (cx + r * 6 // 10, cy), (cx - r * 6 // 10, cy)
    cv2.arrowedLine(image, tail, tip, WHITE, max(2, r // 7), cv2.LINE_AA, tipLength=0.4)
    return cx - r, cy - r, 2 * r, 2 * r


def lamp(image: NDArray[np.uint8], centre: tuple[int, int], r: int, housing: str) -> BBox:
    """An unlit lamp: its lens in a dark housing (a ring or a box) 1.6 radii wide."""
    cx, cy = centre
    side = int(1.6 * r)
    if housing == "ring":
        cv2.circle(image, centre, side, (30, 30, 30), -1, cv2.LINE_AA)
    else:
        cv2.rectangle(image, (cx - side, cy - side), (cx + side, cy + side), (35, 35, 35), -1)
    cv2.circle(image, centre, r, LENS_RED, -1, cv2.LINE_AA)
    return cx - r, cy - r, 2 * r, 2 * r
