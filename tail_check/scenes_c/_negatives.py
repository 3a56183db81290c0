"""Hard negatives: red things that are not a tail disc."""

from __future__ import annotations

import cv2
import numpy as np

from ._canvas import Cam, Canvas, Colour, jitter, shade
from ._cars import Car

RED: Colour = (35.0, 32.0, 195.0)
ROUND_TEXT = ("0869", "PD", "O8", "9606", "P0D", "6089", "DPO", "808")


def _red(rng: np.random.Generator) -> Colour:
    return jitter(rng, RED, 0.15)


def lettering(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    s = cam.scale(car.z0)
    text = ROUND_TEXT[int(rng.integers(len(ROUND_TEXT)))]
    h_m = rng.uniform(0.15, 0.35)
    scale = h_m * s / 22.0
    thick = max(1, int(round(scale * rng.uniform(2.5, 5))))
    x = rng.uniform(-1.3, 0.2)
    y = car.beam_hi + rng.uniform(0.0, 1.2)
    u, v = cam.p(car.xt + x, y, car.z0)
    font = cv2.FONT_HERSHEY_SIMPLEX if rng.random() < 0.5 else cv2.FONT_HERSHEY_DUPLEX
    cv2.putText(cv.img, text, (int(u), int(v)), font, scale, _red(rng), thick, cv2.LINE_AA)


def stripe(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    y = car.beam_hi + rng.uniform(0.1, 1.5)
    hh = rng.uniform(0.1, 0.3)
    z = car.z0 - 0.01
    col = _red(rng)
    hw = car.half_w
    cv.poly(
        cam.pts(
            [
                (car.xt - hw, y, z),
                (car.xt + hw, y, z),
                (car.xt + hw, y + hh, z),
                (car.xt - hw, y + hh, z),
            ]
        ),
        col,
        z,
    )
    if car.side != 0:
        xs = car.xt + car.side * hw
        pts = cam.pts(
            [(xs, y, car.z0), (xs, y + hh, car.z0), (xs, y + hh, car.z0 + 12), (xs, y, car.z0 + 12)]
        )
        cv.poly(pts, shade(col, 0.9), car.z0 + 0.4)


def logo(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    s = cam.scale(car.z0)
    r = float(np.clip(rng.uniform(0.12, 0.3) * s, 0.01 * cv.h, 0.05 * cv.h))
    x = rng.uniform(-1.2, 1.2)
    y = car.beam_hi + rng.uniform(0.2, 1.8)
    u, v = cam.p(car.xt + x, y, car.z0 - 0.01)
    col = _red(rng)
    cv.ellipse((u, v), (r, r), 0, col, car.z0 - 0.01)
    if rng.random() < 0.5:
        cv.ellipse((u, v), (r * 0.75, r * 0.75), 0, (215.0, 215.0, 215.0), car.z0 - 0.01)
        cv.ellipse((u, v), (r * 0.55, r * 0.55), 0, col, car.z0 - 0.01)
    sc = r / 22.0
    cv2.putText(
        cv.img,
        "RD",
        (int(u - r * 0.6), int(v + r * 0.35)),
        cv2.FONT_HERSHEY_SIMPLEX,
        sc,
        (230, 230, 230),
        max(1, int(sc * 2)),
        cv2.LINE_AA,
    )


def signal(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator, night: bool) -> None:
    side = -1.0 if rng.random() < 0.5 else 1.0
    xp = car.xt + side * rng.uniform(2.6, 3.5)
    zp = car.z0 + rng.uniform(-3, 25)
    col = (40.0, 42.0, 45.0)
    cv.poly(
        cam.pts(
            [(xp - 0.07, 0, zp), (xp + 0.07, 0, zp), (xp + 0.07, 4.5, zp), (xp - 0.07, 4.5, zp)]
        ),
        (120.0, 120.0, 118.0),
        zp,
    )
    cv.poly(
        cam.pts(
            [(xp - 0.3, 3.2, zp), (xp + 0.3, 3.2, zp), (xp + 0.3, 5.0, zp), (xp - 0.3, 5.0, zp)]
        ),
        col,
        zp - 0.01,
    )
    lamps = [4.6, 4.1, 3.6]
    lit = int(rng.integers(len(lamps)))
    for i, yl in enumerate(lamps):
        u, v = cam.p(xp, yl, zp - 0.02)
        r = cam.scale(zp) * 0.11
        c: Colour = (25.0, 25.0, 30.0) if i != lit else (90.0, 90.0, 255.0)
        cv.ellipse((u, v), (r, r), 0, c, zp - 0.02)
        if i == lit:
            cv.add_glow((u, v), r * (3.0 if night else 1.5), (20.0, 30.0, 200.0 if night else 90.0))


def tail_lamp(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator, night: bool) -> None:
    side = -1.0 if rng.random() < 0.5 else 1.0
    x = car.xt + side * rng.uniform(1.0, 1.4)
    y = car.beam_hi + rng.uniform(0.05, 0.4)
    z = car.z0 - 0.15
    s = cam.scale(car.z0)
    r = max(2.0, s * rng.uniform(0.05, 0.09))
    u, v = cam.p(x, y, z)
    cv.poly(
        np.array(
            [
                [u - r * 1.6, v - r * 1.6],
                [u + r * 1.6, v - r * 1.6],
                [u + r * 1.6, v + r * 1.6],
                [u - r * 1.6, v + r * 1.6],
            ],
            np.float64,
        ),
        (30.0, 30.0, 32.0),
        z,
    )
    cv.ellipse((u, v), (r, r), 0, (120.0, 130.0, 255.0), z)
    cv.add_glow((u, v), r * (3.0 if night else 1.6), (30.0, 40.0, 230.0 if night else 120.0))


def hand_wheel(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    s = cam.scale(car.z0)
    x = car.xt + rng.uniform(-1.1, 1.1)
    y = car.beam_hi + rng.uniform(0.3, 1.8)
    u, v = cam.p(x, y, car.z0 - 0.2)
    r = s * rng.uniform(0.2, 0.28)
    col = _red(rng)
    th = max(1.0, r * 0.14)
    c = (int(u * 16), int(v * 16))
    cv2.ellipse(
        cv.img,
        c,
        (int(r * 16), int(r * rng.uniform(0.85, 1.0) * 16)),
        0,
        0,
        360,
        col,
        int(th),
        cv2.LINE_AA,
        4,
    )
    n = int(rng.integers(3, 6))
    for k in range(n):
        a = k * np.pi * 2 / n + rng.uniform(0, 0.3)
        cv.line((u, v), (u + r * np.cos(a), v + r * np.sin(a)), col, th * 0.7)
    cv.ellipse((u, v), (r * 0.15, r * 0.15), 0, shade(col, 0.8), car.z0 - 0.2)


def barrier(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    side = -1.0 if rng.random() < 0.5 else 1.0
    xp = car.xt + side * rng.uniform(3.0, 4.5)
    zp = car.z0 * rng.uniform(0.5, 1.3)
    y = rng.uniform(0.9, 1.2)
    cv.poly(
        cam.pts(
            [
                (xp - 0.12, 0, zp),
                (xp + 0.12, 0, zp),
                (xp + 0.12, y + 0.3, zp),
                (xp - 0.12, y + 0.3, zp),
            ]
        ),
        (60.0, 60.0, 60.0),
        zp,
    )
    length = rng.uniform(3.0, 6.0)
    seg = rng.uniform(0.35, 0.6)
    n = int(length / seg)
    for i in range(n):
        c: Colour = _red(rng) if i % 2 == 0 else (225.0, 225.0, 225.0)
        xa = xp + side * i * seg
        xb = xa + side * seg
        cv.poly(cam.pts([(xa, y, zp), (xb, y, zp), (xb, y + 0.12, zp), (xa, y + 0.12, zp)]), c, zp)
    u, v = cam.p(xp, y + 0.45, zp)
    r = cam.scale(zp) * 0.15
    cv.ellipse((u, v), (r, r), 0, _red(rng), zp)
    cv.ellipse((u, v), (r * 0.7, r * 0.7), 0, (225.0, 225.0, 225.0), zp)


def place_negative(
    kind: str, cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator, night: bool
) -> None:
    if kind == "red_lettering":
        lettering(cv, cam, car, rng)
    elif kind == "red_stripe":
        stripe(cv, cam, car, rng)
    elif kind == "red_logo":
        logo(cv, cam, car, rng)
    elif kind == "signal_light":
        signal(cv, cam, car, rng, night)
    elif kind == "tail_lamp":
        tail_lamp(cv, cam, car, rng, night)
    elif kind == "hand_wheel":
        hand_wheel(cv, cam, car, rng)
    elif kind == "red_barrier":
        barrier(cv, cam, car, rng)
