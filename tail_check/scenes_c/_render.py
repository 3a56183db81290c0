"""Scene assembly for the C generator."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from . import _look
from ._background import draw_scene_background
from ._canvas import F32, Cam, Canvas, jitter, new_canvas, noise_field
from ._cars import CAR_KINDS, Car, draw_car, make_car, pick_colour
from ._disc import Outline, draw_disc, occlude
from ._negatives import place_negative

CONDITIONS: tuple[str, ...] = ("daylight", "overcast", "dusk", "night", "rain", "snow", "fog")
NEGATIVE_KINDS: tuple[str, ...] = (
    "none",
    "red_lettering",
    "red_stripe",
    "red_logo",
    "red_car_body",
    "signal_light",
    "tail_lamp",
    "hand_wheel",
    "red_barrier",
)
DISTRACTORS = (
    "red_lettering",
    "red_stripe",
    "red_logo",
    "signal_light",
    "hand_wheel",
    "red_barrier",
)
ASPECTS = (4 / 3, 16 / 9, 3 / 2, 16 / 10, 5 / 4)


@dataclass(frozen=True)
class Layout:
    cam: Cam
    xt: float
    z0: float


def pick_size(rng: np.random.Generator) -> tuple[int, int]:
    aspect = ASPECTS[int(rng.integers(len(ASPECTS)))]
    w = int(rng.integers(640, 1921))
    h = int(np.clip(round(w / aspect), 480, 1080))
    return w, h


def pick_layout(rng: np.random.Generator, w: int, h: int) -> Layout:
    frac = rng.uniform(0.2, 0.7)
    s = min(frac * w / 3.2, h / 4.3)
    y_r = h * rng.uniform(0.72, 0.94)
    hc = rng.uniform(1.0, 4.0)
    hc = min(hc, (y_r - 0.06 * h) / s)
    vy = y_r - hc * s
    z0 = rng.uniform(8.0, 35.0)
    margin = 1.7 * s + 0.02 * w
    cx = rng.uniform(margin, max(margin + 1.0, w - margin))
    xc = (1.0 if rng.random() < 0.5 else -1.0) * rng.uniform(1.2, 5.0)
    vx = cx - s * xc
    return Layout(Cam(f=s * z0, vx=vx, vy=vy, hc=hc), xc, z0)


def _visible_side(xt: float, half: float) -> float:
    if xt + half < 0:
        return 1.0
    if xt - half > 0:
        return -1.0
    return 0.0


def weather_car(cv: Canvas, car: Car, rng: np.random.Generator) -> None:
    mask = (cv.depth > car.z0 - 1.0) & (cv.depth < car.z0 + 16.0)
    dirt = noise_field(rng, cv.w, cv.h, cv.w / rng.uniform(10, 40))
    grain = noise_field(rng, cv.w, cv.h, 2.0)
    k = 1.0 + rng.uniform(0.05, 0.2) * dirt + 0.05 * grain
    img = cv.img.astype(np.float32)
    img[mask] = img[mask] * k[mask][:, None]
    if rng.random() < 0.2:
        _graffiti(cv, img, mask, rng)
    cv.img[:] = np.clip(img, 0, 255).astype(np.uint8)


def _graffiti(cv: Canvas, img: F32, mask: npt.NDArray[np.bool_], rng: np.random.Generator) -> None:
    layer = np.zeros_like(img)
    for _ in range(int(rng.integers(2, 6))):
        col = jitter(rng, tuple(rng.uniform(30, 230, 3).tolist()), 0.2)
        pts = rng.uniform(0, 1, (5, 2)) * np.array([cv.w, cv.h]) * 0.3
        pts = pts + np.array([rng.uniform(0, cv.w * 0.7), rng.uniform(cv.h * 0.3, cv.h * 0.7)])
        cv2.polylines(layer, [pts.astype(np.int32)], False, col, max(2, cv.w // 120), cv2.LINE_AA)
    on = (layer.sum(axis=2) > 0) & mask
    img[on] = img[on] * 0.3 + layer[on] * 0.7


def roll(img: F32, outline: Outline | None, rng: np.random.Generator) -> tuple[F32, Outline | None]:
    h, w = img.shape[:2]
    ang = float(rng.uniform(-2.5, 2.5))
    m = cv2.getRotationMatrix2D((w / 2, h / 2), ang, 1.0 + abs(ang) * 0.02)
    out = cv2.warpAffine(img, m, (w, h), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT101)
    if outline is None:
        return np.asarray(out, np.float32), None
    pts = outline @ m[:, :2].T + m[:, 2]
    return np.asarray(out, np.float32), pts


def bbox_of(outline: Outline, w: int, h: int) -> tuple[int, int, int, int]:
    x0, y0 = np.floor(outline.min(axis=0)).astype(int)
    x1, y1 = np.ceil(outline.max(axis=0)).astype(int)
    x0, y0 = max(0, int(x0)), max(0, int(y0))
    x1, y1 = min(w, int(x1)), min(h, int(y1))
    return (x0, y0, max(1, x1 - x0), max(1, y1 - y0))


def _dress_car(
    cv: Canvas, car: Car, cam: Cam, rng: np.random.Generator, neg: str | None, cond: str
) -> None:
    night = cond in ("night", "dusk")
    if neg is not None and neg not in ("none", "red_car_body"):
        place_negative(neg, cv, cam, car, rng, night)
    elif neg is None and rng.random() < 0.3:
        place_negative(DISTRACTORS[int(rng.integers(len(DISTRACTORS)))], cv, cam, car, rng, night)


def _discs(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator, cond: str) -> Outline:
    side = 1.0 if rng.random() < 0.6 else -1.0
    lit = cond in ("night", "dusk") and rng.random() < 0.6
    outline = draw_disc(cv, cam, car, rng, side, lit)
    if rng.random() < 0.12:
        other = draw_disc(cv, cam, car, rng, -side, lit)
        if _area(other) > _area(outline):
            outline = other
    if rng.random() < 0.2:
        occlude(cv, outline, rng, cond == "snow")
    return outline


def _area(o: Outline) -> float:
    return float(cv2.contourArea(o.astype(np.float32)))


def compose(
    rng: np.random.Generator, disc: bool, cond: str, size: tuple[int, int], neg: str | None
) -> tuple[npt.NDArray[np.uint8], Outline | None]:
    w, h = size
    lay = pick_layout(rng, w, h)
    cv = new_canvas(w, h)
    draw_scene_background(cv, lay.cam, cond, lay.xt, lay.z0, rng)
    kind = CAR_KINDS[int(rng.integers(len(CAR_KINDS)))]
    colour = pick_colour(rng, neg == "red_car_body")
    half = 1.55 if kind == "tank" else 1.6
    car = make_car(rng, kind, lay.xt, lay.z0, colour, _visible_side(lay.xt, half))
    sun = rng.uniform(0.55, 1.25) if cond == "daylight" else rng.uniform(0.8, 0.95)
    draw_car(cv, lay.cam, car, rng, sun)
    weather_car(cv, car, rng)
    _dress_car(cv, car, lay.cam, rng, neg, cond)
    outline = _discs(cv, lay.cam, car, rng, cond) if disc else None
    if cond == "snow":
        _look.snow_cover(cv, rng)
    img = _look.light(cv, cond, rng)
    img = _look.weather(cv, img, cond, rng)
    img, outline = roll(img, outline, rng)
    return _look.camera(img, cond, rng), outline
