"""Drawing of a last-car scene for the snapshot generator (float RGB canvas, 0..1).

Geometry follows a fixed tail camera looking along the track at the rear of the
last car: the car body, the buffer beam with two buffers and the coupler, bogies
and rails below, and the tail disc at the buffer beam on the right side.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

FloatImage = NDArray[np.float32]
Mask = NDArray[np.bool_]

CAR_COLOURS: dict[str, tuple[float, float, float]] = {
    # RGB 0..1; red-brown, rust and signal red sit close to the disc on purpose.
    "grey": (0.47, 0.48, 0.46),
    "green": (0.22, 0.36, 0.24),
    "blue": (0.18, 0.27, 0.43),
    "black": (0.12, 0.12, 0.13),
    "white": (0.80, 0.80, 0.77),
    "red_brown": (0.42, 0.17, 0.13),
    "rust": (0.55, 0.28, 0.17),
    "brown": (0.33, 0.22, 0.15),
    "orange": (0.80, 0.42, 0.14),
    "red": (0.70, 0.15, 0.14),
}


@dataclass(frozen=True)
class CarGeometry:
    """Pixel geometry of the drawn car rear."""

    left: int
    right: int
    top: int
    beam_top: int
    beam_bottom: int
    disc_zone_taken: bool = False

    @property
    def width(self) -> int:
        return self.right - self.left


def _noise(rng: np.random.Generator, h: int, w: int, scale: float) -> FloatImage:
    """Smooth noise field in about -1..1 with features of ``scale`` pixels."""
    sh, sw = max(2, int(h / max(scale, 1.0))), max(2, int(w / max(scale, 1.0)))
    small = rng.standard_normal((sh, sw)).astype(np.float32)
    return np.asarray(cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC), dtype=np.float32)


def background(
    rng: np.random.Generator, h: int, w: int, sky: tuple[float, float, float]
) -> FloatImage:
    """Sky, a tree line, ballast and two rails converging to the horizon."""
    img = np.empty((h, w, 3), np.float32)
    horizon = int(h * rng.uniform(0.30, 0.48))
    t = np.linspace(0.0, 1.0, horizon, dtype=np.float32)[:, None]
    sky_top = np.array(sky, np.float32) * 0.8
    img[:horizon] = (sky_top * (1 - t) + np.array(sky, np.float32) * t)[:, None, :]
    if rng.random() < 0.6:
        band = int(h * rng.uniform(0.05, 0.12))
        trees = (
            np.array([0.16, 0.26, 0.14], np.float32)
            * (1 + 0.35 * _noise(rng, band, w, h / 40))[..., None]
        )
        img[max(0, horizon - band) : horizon] = trees[-min(band, horizon) :]
    ground = np.array([0.36, 0.33, 0.30], np.float32) * rng.uniform(0.8, 1.15)
    tex = 1 + 0.18 * _noise(rng, h - horizon, w, 2.0) + 0.1 * _noise(rng, h - horizon, w, 12.0)
    img[horizon:] = ground * tex[..., None]
    vx = w * rng.uniform(0.4, 0.6)
    for foot in (rng.uniform(0.05, 0.3), rng.uniform(0.7, 0.95)):
        cv2.line(img, (int(vx), horizon), (int(foot * w), h), (0.55, 0.55, 0.55), max(1, w // 150))
    return img


def draw_car(
    rng: np.random.Generator,
    img: FloatImage,
    colour: tuple[float, float, float],
    width: tuple[float, float] = (0.5, 0.88),
) -> CarGeometry:
    """Draw the car rear (body, ribs, dirt, stencils, buffer beam, buffers, bogie).

    ``width``: range of the car's width as a fraction of the image's (its distance).
    """
    h, w = img.shape[:2]
    cw = w * rng.uniform(*width)
    cx = w * 0.5 + w * rng.uniform(-0.08, 0.08)
    left, right = int(cx - cw / 2), int(cx + cw / 2)
    beam_top = int(h * rng.uniform(0.60, 0.80))
    beam_bottom = beam_top + int(cw * rng.uniform(0.07, 0.10))
    top = int(beam_top - cw * rng.uniform(0.75, 1.05))
    geo = CarGeometry(max(left, 0), min(right, w), max(top, 0), beam_top, beam_bottom)
    bh, bw = beam_top - geo.top, geo.width
    body = np.array(colour, np.float32) * (1 + 0.12 * _noise(rng, bh, bw, cw / 6))[..., None]
    dirt = np.clip(_noise(rng, bh, bw, cw / 20), 0, None)[..., None]
    body = body * (1 - 0.25 * dirt) + np.array([0.30, 0.22, 0.15], np.float32) * 0.25 * dirt
    pitch = max(4, int(cw * rng.uniform(0.08, 0.14)))
    for x in range(pitch // 2, bw, pitch):  # vertical ribs: light edge, shadowed edge
        body[:, x : x + max(1, pitch // 10)] *= 1.18
        body[:, x + max(1, pitch // 10) : x + max(2, pitch // 5)] *= 0.75
    img[geo.top : beam_top, geo.left : geo.right] = body
    for _ in range(rng.integers(1, 4)):  # white stencils
        sx = geo.left + int(bw * rng.uniform(0.05, 0.6))
        sy = geo.top + int(bh * rng.uniform(0.1, 0.7))
        cv2.rectangle(
            img,
            (sx, sy),
            (sx + int(cw * rng.uniform(0.1, 0.3)), sy + max(2, int(cw * 0.03))),
            (0.85, 0.85, 0.82),
            -1,
        )
    beam_colour = np.array(colour, np.float32) * 0.35 if rng.random() < 0.5 else np.full(3, 0.1)
    cv2.rectangle(img, (geo.left, beam_top), (geo.right, beam_bottom), beam_colour.tolist(), -1)
    under = min(h, beam_bottom + int(cw * 0.35))
    img[beam_bottom:under, geo.left : geo.right] *= 0.25
    for bx in (left + 0.12 * cw, right - 0.12 * cw):  # buffers: stem and round plate
        by = (beam_top + beam_bottom) // 2
        rad = int(cw * rng.uniform(0.045, 0.06))
        cv2.circle(img, (int(bx), by), rad, (0.18, 0.18, 0.19), -1, cv2.LINE_AA)
        cv2.circle(
            img,
            (int(bx - rad * 0.25), by - int(rad * 0.25)),
            max(1, rad // 3),
            (0.45, 0.45, 0.45),
            -1,
        )
    cv2.rectangle(
        img,
        (int(cx - cw * 0.04), beam_top),
        (int(cx + cw * 0.04), beam_bottom + int(cw * 0.03)),
        (0.15, 0.15, 0.15),
        -1,
    )
    return geo


def disc_colour(rng: np.random.Generator, *, weak: bool) -> NDArray[np.float32]:
    """Signal red of a real disc: fresh, faded or dirty; ``weak``: dirty and dull."""
    base = np.array([rng.uniform(0.74, 0.88), rng.uniform(0.07, 0.17), rng.uniform(0.08, 0.19)])
    if weak:
        base = base * rng.uniform(0.6, 0.8) + 0.06 * rng.uniform(0, 1)
    return base.astype(np.float32)


def draw_disc(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, *, weak: bool
) -> tuple[Mask, tuple[int, int], tuple[int, int], float]:
    """Draw the tail disc at the buffer beam, right side, on its bracket.

    Returns the disc mask, its centre, its reflector radius and the disc radius
    (in pixels).
    """
    h, w = img.shape[:2]
    cw = geo.width
    r = cw * rng.uniform(0.042, 0.06)
    cx = int(geo.right - cw * rng.uniform(0.16, 0.26))
    cy = int(geo.beam_top - r * rng.uniform(-0.2, 0.7))
    squash = rng.uniform(0.82, 1.0)
    axes = (max(2, int(r * squash)), max(2, int(r)))
    angle = rng.uniform(-8, 8)
    # bracket, then a soft shadow on the body behind the disc
    cv2.rectangle(
        img, (cx - 1, cy), (cx + max(1, int(r * 0.15)), geo.beam_bottom), (0.1, 0.1, 0.1), -1
    )
    shadow = np.zeros((h, w), np.float32)
    cv2.ellipse(
        shadow,
        (cx + int(r * 0.2), cy + int(r * 0.15)),
        (axes[0] + 2, axes[1] + 2),
        angle,
        0,
        360,
        1.0,
        -1,
    )
    shadow = np.asarray(cv2.GaussianBlur(shadow, (0, 0), max(1.0, r * 0.15)), np.float32)
    img *= (1 - 0.55 * shadow)[..., None]
    rim = max(1, int(round(r * rng.uniform(0.05, 0.09))))
    cv2.ellipse(
        img,
        (cx, cy),
        (axes[0] + rim, axes[1] + rim),
        angle,
        0,
        360,
        (0.07, 0.07, 0.07),
        -1,
        cv2.LINE_AA,
    )
    mask_u8 = np.zeros((h, w), np.uint8)
    cv2.ellipse(mask_u8, (cx, cy), axes, angle, 0, 360, 1, -1, cv2.LINE_AA)
    mask = mask_u8 > 0
    colour = disc_colour(rng, weak=weak)
    ys, xs = np.nonzero(mask)
    gx, gy = rng.uniform(-0.15, 0.15, 2)
    shade = 1 + gx * (xs - cx) / r + gy * (ys - cy) / r  # uneven paint and light
    patch = _noise(rng, h, w, max(2.0, r / 3))[ys, xs]
    shade = shade * (1 - (0.35 if weak else 0.12) * np.clip(patch, 0, None))
    img[ys, xs] = colour[None, :] * shade[:, None].astype(np.float32)
    refl_r = max(1, int(r * rng.uniform(0.14, 0.22)))
    cv2.circle(img, (cx, cy), refl_r, (0.62, 0.16, 0.14), -1, cv2.LINE_AA)
    cv2.circle(img, (cx - refl_r // 3, cy - refl_r // 3), max(1, refl_r // 3), (0.9, 0.7, 0.65), -1)
    return mask, (cx, cy), (refl_r, rim), float(r)
