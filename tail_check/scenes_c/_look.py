"""Light, weather and camera effects for the C scenes."""

from __future__ import annotations

import cv2
import numpy as np

from ._canvas import F32, SKY_DEPTH, U8, Canvas, noise_field


def _grade(img: F32, gain: float, contrast: float, cast: tuple[float, float, float]) -> F32:
    mean = float(img.mean())
    out = (img - mean) * contrast + mean
    return (out * gain * np.array(cast, np.float32)).astype(np.float32)


def light(cv: Canvas, cond: str, rng: np.random.Generator) -> F32:
    img = cv.img.astype(np.float32)
    sky = cv.depth >= SKY_DEPTH
    ground = img.copy()
    if cond == "daylight":
        out = _grade(img, rng.uniform(1.0, 1.15), rng.uniform(1.05, 1.25), (1.0, 1.0, 1.03))
    elif cond == "overcast":
        out = _grade(img, rng.uniform(0.85, 1.0), rng.uniform(0.6, 0.8), (1.03, 1.0, 0.97))
    elif cond == "dusk":
        cast = (0.8, 0.9, 1.15) if rng.random() < 0.5 else (1.2, 0.95, 0.8)
        out = _grade(img, rng.uniform(0.3, 0.55), 0.9, cast)
    elif cond == "night":
        out = _grade(img, rng.uniform(0.06, 0.16), 1.0, (1.3, 1.0, 0.8))
        out = out * _lamp_pool(cv, rng)[..., None]
    elif cond == "rain":
        out = _grade(img, rng.uniform(0.55, 0.8), 0.75, (1.05, 1.0, 0.95))
    elif cond == "snow":
        out = _grade(img, rng.uniform(0.9, 1.05), 0.8, (1.05, 1.0, 0.97))
    else:
        out = _grade(img, rng.uniform(0.9, 1.0), 0.85, (1.0, 1.0, 1.0))
    if cond not in ("night", "dusk"):
        out[sky] = ground[sky] * 0.3 + out[sky] * 0.7
    return out.astype(np.float32)


def _lamp_pool(cv: Canvas, rng: np.random.Generator) -> F32:
    yy, xx = np.mgrid[0 : cv.h, 0 : cv.w].astype(np.float32)
    cx, cy = rng.uniform(0.2, 0.8) * cv.w, rng.uniform(0.3, 0.9) * cv.h
    r = rng.uniform(0.3, 0.7) * cv.w
    pool = 1.0 + rng.uniform(1.5, 4.0) * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (r * r))
    return np.asarray(pool, dtype=np.float32)


def fog(img: F32, depth: F32, rng: np.random.Generator, vis: float) -> F32:
    t = 1.0 - np.exp(-np.minimum(depth, 500.0) / vis)
    grey = np.array([200.0, 200.0, 198.0], np.float32) * rng.uniform(0.85, 1.05)
    return (img * (1 - t[..., None]) + grey * t[..., None]).astype(np.float32)


def rain(img: F32, rng: np.random.Generator) -> F32:
    h, w = img.shape[:2]
    layer = np.zeros((h, w), np.float32)
    n = int(w * h / 900)
    xs, ys = rng.uniform(0, w, n), rng.uniform(0, h, n)
    ln = rng.uniform(0.02, 0.06, n) * h
    ang = rng.uniform(-0.25, 0.05)
    for x, y, length in zip(xs, ys, ln, strict=True):
        cv2.line(
            layer, (int(x), int(y)), (int(x + ang * length), int(y + length)), 1.0, 1, cv2.LINE_AA
        )
    layer = np.asarray(cv2.GaussianBlur(layer, (0, 0), 0.8), np.float32)
    out = img * 0.92 + layer[..., None] * rng.uniform(40, 80)
    return _droplets(out.astype(np.float32), rng)


def _droplets(img: F32, rng: np.random.Generator) -> F32:
    h, w = img.shape[:2]
    blurred = cv2.GaussianBlur(img, (0, 0), max(2.0, w / 200))
    mask = np.zeros((h, w), np.float32)
    for _ in range(int(rng.integers(3, 15))):
        r = rng.uniform(0.01, 0.04) * w
        cv2.circle(
            mask, (int(rng.uniform(0, w)), int(rng.uniform(0, h))), int(r), 1.0, -1, cv2.LINE_AA
        )
    mask = np.asarray(cv2.GaussianBlur(mask, (0, 0), 2.0), np.float32)[..., None]
    return (img * (1 - mask) + blurred * mask * 1.05).astype(np.float32)


def snow(img: F32, rng: np.random.Generator) -> F32:
    h, w = img.shape[:2]
    layer = np.zeros((h, w), np.float32)
    n = int(w * h / rng.uniform(400, 1500))
    xs, ys = rng.uniform(0, w, n), rng.uniform(0, h, n)
    rs = rng.uniform(0.5, 1.0, n) ** 3 * w / 250 + 0.6
    for x, y, r in zip(xs, ys, rs, strict=True):
        cv2.circle(layer, (int(x * 4), int(y * 4)), int(r * 4), 1.0, -1, cv2.LINE_AA, 2)
    layer = np.asarray(cv2.GaussianBlur(layer, (0, 0), 0.9), np.float32)
    a = np.clip(layer * rng.uniform(0.6, 0.95), 0, 1)[..., None]
    return np.asarray(img * (1 - a) + 235.0 * a, dtype=np.float32)


def snow_cover(cv: Canvas, rng: np.random.Generator) -> None:
    """Whiten the upper edges of horizontal surfaces (beam top, roof, sleepers)."""
    img = cv.img.astype(np.float32)
    grey = img.mean(axis=2)
    edge = np.zeros_like(grey)
    edge[1:] = np.clip(grey[:-1] - grey[1:], 0, 255) / 255.0
    kernel = np.ones((max(2, cv.h // 200), 1), np.float32)
    mask = cv2.dilate(edge, kernel) * np.clip(noise_field(rng, cv.w, cv.h, 6) + 0.6, 0, 1)
    mask = np.clip(mask * 2.5, 0, 1)[..., None]
    cv.img[:] = np.clip(img * (1 - mask) + 230.0 * mask, 0, 255).astype(np.uint8)


def weather(cv: Canvas, img: F32, cond: str, rng: np.random.Generator) -> F32:
    if cond == "fog":
        img = fog(img, cv.depth, rng, rng.uniform(25, 90))
    elif cond in ("rain", "snow", "overcast"):
        img = fog(img, cv.depth, rng, rng.uniform(150, 400))
    elif cond == "dusk":
        img = fog(img, cv.depth, rng, 600.0) * 0.5 + img * 0.5
    glow_gain = {"night": 1.0, "dusk": 0.7}.get(cond, 0.35)
    glow = cv.glow * glow_gain
    if cond in ("night", "dusk", "fog", "rain"):
        glow = glow + cv2.GaussianBlur(glow, (0, 0), max(2.0, cv.w / 150)) * 0.8
    img = img + glow
    if cond == "rain":
        img = rain(img, rng)
    elif cond == "snow":
        img = snow(img, rng)
    return img


def camera(img: F32, cond: str, rng: np.random.Generator) -> U8:
    h, w = img.shape[:2]
    img = img * float(2.0 ** rng.normal(0, 0.25))
    if rng.random() < 0.25:
        k = int(rng.integers(3, 10))
        ker = np.zeros((k, k), np.float32)
        ker[k // 2, :] = 1.0 / k
        img = np.asarray(cv2.filter2D(img, -1, ker), np.float32)
    elif rng.random() < 0.5:
        img = np.asarray(cv2.GaussianBlur(img, (0, 0), rng.uniform(0.4, 1.0)), np.float32)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    rr = ((xx - w / 2) / (w / 2)) ** 2 + ((yy - h / 2) / (h / 2)) ** 2
    img = img * (1.0 - rng.uniform(0.05, 0.35) * rr / 2)[..., None]
    sigma = {"night": rng.uniform(6, 14), "dusk": rng.uniform(3, 7)}.get(
        cond, rng.uniform(1.0, 4.0)
    )
    img = img + rng.normal(0, sigma, (h, w, 1)).astype(np.float32) * 0.7
    img = img + rng.normal(0, sigma * 0.6, (h, w, 3)).astype(np.float32)
    out = np.clip(img, 0, 255).astype(np.uint8)
    q = int(rng.integers(50, 96))
    ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, q])
    if not ok:
        return out
    dec = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return np.asarray(dec, dtype=np.uint8)
