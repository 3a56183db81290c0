"""Red objects that are not tail discs, drawn on the generated last-car scene."""

from __future__ import annotations

import math

import cv2
import numpy as np

from ._scene import CarGeometry, FloatImage

DISTRACTORS = ("red_plate", "red_logo", "hand_wheel", "red_lamp", "red_stripe", "red_square")
Paint = tuple[float, float, float]
_RED: Paint = (0.78, 0.12, 0.12)
_WHITE = (0.88, 0.88, 0.86)


def _spot(rng: np.random.Generator, geo: CarGeometry, *, low: bool) -> tuple[int, int]:
    """A point on the car body; ``low``: where a disc would be (right, near the beam)."""
    if low and not geo.disc_zone_taken:
        x = geo.right - geo.width * rng.uniform(0.12, 0.35)
        y = geo.beam_top - geo.width * rng.uniform(0.05, 0.15)
    else:
        x = geo.left + geo.width * rng.uniform(0.15, 0.85)
        y = geo.top + (geo.beam_top - geo.top) * rng.uniform(0.15, 0.6)
    return int(x), int(y)


def _glyphs(img: FloatImage, x: float, y: float, w: float, h: float) -> None:
    """White letter-like strokes in the box (x, y, w, h): numbers on plates, logo letters."""
    n = 4
    step = w / n
    t = max(1, int(step * 0.18))
    for k in range(n):
        x0 = int(x + k * step + step * 0.15)
        x1 = int(x + (k + 1) * step - step * 0.15)
        cv2.rectangle(img, (x0, int(y)), (x0 + t, int(y + h)), _WHITE, -1)
        cv2.rectangle(img, (x0, int(y)), (x1, int(y) + t), _WHITE, -1)
        if k % 2:
            cv2.rectangle(img, (x1 - t, int(y)), (x1, int(y + h)), _WHITE, -1)


def _plate(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, *, square: bool, red: Paint
) -> None:
    cx, cy = _spot(rng, geo, low=rng.random() < 0.6)
    d = geo.width * rng.uniform(0.08, 0.12)
    pw = d * (rng.uniform(0.85, 1.15) if square else rng.uniform(1.5, 3.0))
    ph = d * (rng.uniform(0.85, 1.15) if square else rng.uniform(0.5, 1.1))
    box = cv2.boxPoints(((cx, cy), (pw, ph), rng.uniform(-12, 12))).astype(np.int32)
    cv2.fillConvexPoly(img, box, red, cv2.LINE_AA)
    if not square and rng.random() < 0.6:  # white numbers on the plate
        _glyphs(img, cx - pw * 0.35, cy - ph * 0.25, pw * 0.7, ph * 0.5)


def _logo(rng: np.random.Generator, img: FloatImage, geo: CarGeometry, red: Paint) -> None:
    cx, cy = _spot(rng, geo, low=rng.random() < 0.4)
    s = geo.width * rng.uniform(0.1, 0.3)
    pts = np.array(
        [
            [cx - s, cy + s * 0.4],
            [cx - s * 0.6, cy - s * 0.4],
            [cx + s, cy - s * 0.4],
            [cx + s * 0.6, cy + s * 0.4],
        ],
        np.int32,
    )
    cv2.fillConvexPoly(img, pts, red, cv2.LINE_AA)
    _glyphs(img, cx - s * 0.5, cy - s * 0.25, s, s * 0.5)


def _hand_wheel(rng: np.random.Generator, img: FloatImage, geo: CarGeometry, red: Paint) -> None:
    cx, cy = _spot(rng, geo, low=rng.random() < 0.5)
    r = geo.width * rng.uniform(0.04, 0.08)
    t = max(1, int(r * 0.15))
    cv2.circle(img, (cx, cy), int(r), red, t, cv2.LINE_AA)
    for k in range(4):
        a = math.pi * k / 4 + rng.uniform(0, 0.5)
        dx, dy = int(r * math.cos(a)), int(r * math.sin(a))
        cv2.line(img, (cx - dx, cy - dy), (cx + dx, cy + dy), red, max(1, t // 2), cv2.LINE_AA)


def _lamp(rng: np.random.Generator, img: FloatImage) -> None:
    h, w = img.shape[:2]
    x, y = int(w * rng.uniform(0.05, 0.95)), int(h * rng.uniform(0.2, 0.5))
    r = max(1, int(math.sqrt(w * h) * rng.uniform(0.004, 0.01)))
    cv2.rectangle(img, (x - r, y - r), (x + r, y + 4 * r), (0.05, 0.05, 0.05), -1)
    cv2.circle(img, (x, y), r, (1.0, 0.15, 0.12), -1, cv2.LINE_AA)


def draw_distractor(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, kind: str, red: Paint = _RED
) -> None:
    """Draw one red non-disc object of the given ``kind`` (see ``DISTRACTORS``) in the
    paint ``red`` (RGB 0..1; the lamp is always lit signal red)."""
    if kind == "red_plate":
        _plate(rng, img, geo, square=False, red=red)
    elif kind == "red_square":
        _plate(rng, img, geo, square=True, red=red)
    elif kind == "red_logo":
        _logo(rng, img, geo, red)
    elif kind == "hand_wheel":
        _hand_wheel(rng, img, geo, red)
    elif kind == "red_lamp":
        _lamp(rng, img)
    elif kind == "red_stripe":
        y = int(geo.top + (geo.beam_top - geo.top) * rng.uniform(0.15, 0.6))
        th = max(2, int(geo.width * rng.uniform(0.03, 0.08)))
        cv2.rectangle(img, (geo.left, y), (geo.right, y + th), red, -1)
    else:
        raise ValueError(f"unknown distractor {kind!r}; use one of {DISTRACTORS}")
