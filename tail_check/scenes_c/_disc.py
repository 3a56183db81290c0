"""The tail disc on its bracket."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from ._canvas import Cam, Canvas, Colour, jitter
from ._cars import Car

Outline = npt.NDArray[np.float64]


def disc_outline(centre: tuple[float, float], ax: tuple[float, float], angle: float) -> Outline:
    t = np.linspace(0, 2 * np.pi, 48, endpoint=False)
    ca, sa = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    x, y = ax[0] * np.cos(t), ax[1] * np.sin(t)
    return np.stack([centre[0] + ca * x - sa * y, centre[1] + sa * x + ca * y], axis=1)


def _colours(rng: np.random.Generator) -> tuple[Colour, Colour, Colour]:
    red = jitter(rng, (35.0, 30.0, 205.0), 0.12)
    if rng.random() < 0.3:  # faded / dirty
        k = rng.uniform(0.2, 0.5)
        dirt = (70.0, 80.0, 120.0)
        red = (
            red[0] * (1 - k) + dirt[0] * k,
            red[1] * (1 - k) + dirt[1] * k,
            red[2] * (1 - k) + dirt[2] * k,
        )
    rim_kind = rng.choice(["white", "dark", "none"], p=[0.45, 0.3, 0.25])
    rim = {"white": (215.0, 215.0, 210.0), "dark": (35.0, 35.0, 38.0), "none": red}[str(rim_kind)]
    centre = jitter(rng, (40.0, 70.0, 245.0) if rng.random() < 0.5 else (50.0, 45.0, 240.0), 0.08)
    return red, rim, centre


def draw_disc(
    cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator, side: float, lit: bool
) -> Outline:
    s = cam.scale(car.z0)
    d_px = float(np.clip(rng.uniform(0.22, 0.34) * s, 0.015 * cv.h, 0.08 * cv.h))
    r_m = d_px / s / 2
    x = side * rng.uniform(1.0, 1.35)
    y = car.beam_hi + rng.uniform(-0.1, 0.45) + r_m
    z = car.z0 - 0.15
    cu, cvv = cam.p(car.xt + x, y, z)
    bw = max(1.0, s * 0.04)
    cv.line((cu, cvv), cam.p(car.xt + x, car.beam_hi - 0.1, z), (30.0, 30.0, 30.0), bw * 1.5)
    cv.line(
        cam.p(car.xt + x - 0.08, car.beam_hi, z),
        cam.p(car.xt + x + 0.08, car.beam_hi, z),
        (30.0, 30.0, 30.0),
        bw,
    )
    r = d_px / 2
    turn = float(np.cos(np.radians(rng.uniform(0, 45)))) if rng.random() < 0.5 else 1.0
    ax = (r * turn, r)
    angle = float(rng.uniform(-8, 8))
    red, rim, cen = _colours(rng)
    cv.ellipse((cu, cvv), ax, angle, rim, z)
    rim_w = rng.uniform(0.08, 0.16) if rim != red else 0.0
    cv.ellipse((cu, cvv), (ax[0] * (1 - rim_w), ax[1] * (1 - rim_w)), angle, red, z)
    if rng.random() < 0.8:
        k = rng.uniform(0.3, 0.55)
        cv.ellipse((cu, cvv), (ax[0] * k, ax[1] * k), angle, cen, z)
    if lit:
        cv.add_glow((cu, cvv), r * rng.uniform(0.5, 1.0), (20.0, 40.0, rng.uniform(120, 220)))
    return disc_outline((cu, cvv), ax, angle)


def occlude(cv: Canvas, outline: Outline, rng: np.random.Generator, snowy: bool) -> None:
    """Cover at most about 30 % of the disc with a pole, a clump of snow or a branch."""
    x0, y0 = outline.min(axis=0)
    x1, y1 = outline.max(axis=0)
    w, h = x1 - x0, y1 - y0
    if snowy and rng.random() < 0.6:
        cy = y0 + h * rng.uniform(-0.05, 0.1)
        cv.ellipse(
            (x0 + w * rng.uniform(0.3, 0.7), cy), (w * 0.45, h * 0.2), 0, (230.0, 230.0, 228.0), 0.5
        )
        return
    bw = w * rng.uniform(0.12, 0.22)
    xc = x0 + w * rng.choice([rng.uniform(0.05, 0.25), rng.uniform(0.75, 0.95)])
    col = jitter(rng, (60.0, 65.0, 70.0), 0.3)
    pts = np.array(
        [[xc - bw / 2, 0], [xc + bw / 2, 0], [xc + bw / 2, cv.h], [xc - bw / 2, cv.h]], np.float64
    )
    cv.poly(pts, col, 0.5)
