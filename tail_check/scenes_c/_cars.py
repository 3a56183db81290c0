"""Freight car rear ends (box car, gondola, hopper, tank, container flat)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ._canvas import Cam, Canvas, Colour, circle3, jitter, shade

CAR_KINDS = ("box", "gondola", "hopper", "tank", "flat")
OXIDES: tuple[Colour, ...] = (
    (35, 45, 120),
    (40, 55, 140),
    (45, 50, 105),
    (30, 40, 95),
    (50, 70, 150),
    (38, 48, 160),
    (30, 35, 80),
    (55, 75, 125),
)
OTHERS: tuple[Colour, ...] = (
    (120, 120, 118),
    (150, 150, 150),
    (60, 95, 55),
    (130, 80, 40),
    (40, 40, 42),
    (60, 85, 110),
    (200, 200, 200),
    (70, 130, 160),
)
BRIGHT_RED: tuple[Colour, ...] = ((40, 35, 190), (30, 30, 170), (45, 45, 205), (35, 25, 150))


@dataclass(frozen=True)
class Car:
    kind: str
    xt: float
    z0: float
    half_w: float
    top: float
    beam_lo: float
    beam_hi: float
    colour: Colour
    side: float  # +1 right face visible, -1 left, 0 none


def pick_colour(rng: np.random.Generator, red_body: bool) -> Colour:
    if red_body:
        return jitter(rng, BRIGHT_RED[int(rng.integers(len(BRIGHT_RED)))], 0.1)
    if rng.random() < 0.55:
        return jitter(rng, OXIDES[int(rng.integers(len(OXIDES)))], 0.15)
    return jitter(rng, OTHERS[int(rng.integers(len(OTHERS)))], 0.15)


def _front(
    cv: Canvas,
    cam: Cam,
    car: Car,
    box: tuple[float, float, float, float],
    c: Colour,
    dz: float = 0.0,
) -> None:
    x0, y0, x1, y1 = box
    z = car.z0 - dz
    pts = cam.pts(
        [(car.xt + x0, y0, z), (car.xt + x1, y0, z), (car.xt + x1, y1, z), (car.xt + x0, y1, z)]
    )
    cv.poly(pts, c, z)


def _side_quad(
    cv: Canvas, cam: Cam, car: Car, x: float, y0: float, y1: float, z1: float, c: Colour
) -> None:
    xs = car.xt + x
    pts = cam.pts([(xs, y0, car.z0), (xs, y1, car.z0), (xs, y1, z1), (xs, y0, z1)])
    cv.poly(pts, c, car.z0 + 0.5)


def _side_ribs(
    cv: Canvas,
    cam: Cam,
    car: Car,
    x: float,
    y0: float,
    y1: float,
    length: float,
    step: float,
    c: Colour,
) -> None:
    xs = car.xt + x
    z = car.z0 + step
    while z < car.z0 + length:
        cv.line(cam.p(xs, y0, z), cam.p(xs, y1, z), c, max(1.0, cam.scale(z) * 0.08))
        z += step


def draw_running_gear(cv: Canvas, cam: Cam, car: Car, length: float) -> None:
    dark = (30.0, 32.0, 35.0)
    for zc in (car.z0 + length - 2.0, car.z0 + 2.0):
        for sx in (-0.76, 0.76):
            x = car.xt + sx
            for dzw in (-0.9, 0.9):
                cv.poly(cam.pts(circle3(x, 0.47, zc + dzw, 0.47, 20, "x")), (45.0, 45.0, 48.0), zc)
            frame = [
                (x, 0.35, zc - 1.3),
                (x, 0.8, zc - 1.3),
                (x, 0.8, zc + 1.3),
                (x, 0.35, zc + 1.3),
            ]
            cv.poly(cam.pts(frame), dark, zc)
    _front(cv, cam, car, (-1.2, 0.55, 1.2, 0.95), (25.0, 26.0, 28.0), -1.2)


def draw_body_side(
    cv: Canvas, cam: Cam, car: Car, length: float, rng: np.random.Generator, sun: float
) -> None:
    if car.side == 0:
        return
    x = car.side * car.half_w
    c = shade(car.colour, sun)
    z1 = car.z0 + length
    if car.kind == "tank":
        return
    y0 = car.beam_lo if car.kind != "flat" else car.beam_lo
    top = car.top if car.kind != "flat" else 1.55
    _side_quad(cv, cam, car, x, y0, top, z1, c)
    if car.kind == "flat":
        _side_quad(
            cv,
            cam,
            car,
            car.side * 1.22,
            1.55,
            car.top,
            car.z0 + 12.2,
            c,
        )
    step = {"box": 0.7, "gondola": 1.3, "hopper": 1.6, "flat": 0.3}[car.kind]
    xr = x if car.kind != "flat" else car.side * 1.22
    _side_ribs(
        cv,
        cam,
        car,
        xr,
        max(y0, 1.3),
        top if car.kind != "flat" else car.top,
        length if car.kind != "flat" else 12.2,
        step,
        shade(c, 0.75),
    )
    if car.kind == "box":
        zd = car.z0 + length * rng.uniform(0.4, 0.5)
        xs = car.xt + x
        pts = cam.pts(
            [
                (xs, 1.4, zd),
                (xs, car.top - 0.3, zd),
                (xs, car.top - 0.3, zd + 3.0),
                (xs, 1.4, zd + 3.0),
            ]
        )
        cv.poly(pts, shade(c, 0.85), car.z0 + 1)


def draw_box_end(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    hw, c = car.half_w, car.colour
    _front(cv, cam, car, (-hw, car.beam_hi, hw, car.top - 0.25), c)
    arc = [
        (car.xt + hw * np.cos(a), car.top - 0.25 + 0.3 * np.sin(a), car.z0)
        for a in np.linspace(0, np.pi, 16)
    ]
    cv.poly(cam.pts([(float(x), float(y), z) for x, y, z in arc]), shade(c, 1.05), car.z0)
    n = int(rng.integers(5, 9))
    for i in range(n):
        x = -hw + (i + 0.5) * 2 * hw / n
        _front(
            cv,
            cam,
            car,
            (x - 0.06, car.beam_hi + 0.1, x + 0.06, car.top - 0.3),
            shade(c, 1.15),
            0.02,
        )
        _front(
            cv, cam, car, (x + 0.06, car.beam_hi + 0.1, x + 0.1, car.top - 0.3), shade(c, 0.7), 0.02
        )


def draw_gondola_end(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    hw, c = car.half_w, car.colour
    _front(cv, cam, car, (-hw, car.beam_hi, hw, car.top), c)
    _front(cv, cam, car, (-hw, car.top - 0.12, hw, car.top), shade(c, 1.2), 0.03)
    for y in np.linspace(car.beam_hi + 0.4, car.top - 0.4, int(rng.integers(1, 4))):
        _front(cv, cam, car, (-hw, float(y) - 0.05, hw, float(y) + 0.05), shade(c, 0.75), 0.03)
    for x in (-hw + 0.06, -0.45, 0.45, hw - 0.06):
        _front(cv, cam, car, (x - 0.06, car.beam_hi, x + 0.06, car.top), shade(c, 0.8), 0.04)


def draw_hopper_end(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    hw, c = car.half_w, car.colour
    _front(cv, cam, car, (-hw, car.beam_hi + 0.5, hw, car.top), c)
    zt = car.z0 + 0.8
    pts = cam.pts(
        [
            (car.xt - hw, car.beam_hi + 0.5, car.z0),
            (car.xt + hw, car.beam_hi + 0.5, car.z0),
            (car.xt + 0.6, car.beam_hi - 0.2, zt),
            (car.xt - 0.6, car.beam_hi - 0.2, zt),
        ]
    )
    cv.poly(pts, shade(c, 0.6), zt)
    for y in np.arange(car.beam_hi + 0.9, car.top - 0.2, rng.uniform(0.5, 0.8)):
        _front(cv, cam, car, (-hw, float(y) - 0.04, hw, float(y) + 0.04), shade(c, 0.7), 0.02)
    _front(cv, cam, car, (-hw, car.top - 0.1, hw, car.top), shade(c, 1.2), 0.02)


def draw_tank(cv: Canvas, cam: Cam, car: Car, length: float, sun: float) -> None:
    r, cy = car.half_w * 0.92, (car.top + car.beam_hi) / 2
    near = cam.pts(circle3(car.xt, cy, car.z0, r, 40))
    far = cam.pts(circle3(car.xt, cy, car.z0 + length, r, 40))
    hull = cv2.convexHull(np.vstack([near, far]).astype(np.float32)).reshape(-1, 2)
    cv.poly(hull.astype(np.float64), shade(car.colour, sun), car.z0 + 1)
    cv.poly(near, car.colour, car.z0)
    hi = cam.pts(circle3(car.xt - 0.3 * r, cy + 0.3 * r, car.z0 - 0.01, r * 0.45, 24))
    cv.poly(hi, shade(car.colour, 1.12), car.z0 - 0.01)
    _front(
        cv, cam, car, (-1.5, car.beam_hi - 0.05, 1.5, car.beam_hi + 0.35), (40.0, 40.0, 42.0), 0.2
    )


def draw_flat_end(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator) -> None:
    c = car.colour
    _front(cv, cam, car, (-1.22, 1.55, 1.22, car.top), c, -0.3)
    for x in (-0.9, -0.35, 0.35, 0.9):
        _front(cv, cam, car, (x - 0.025, 1.6, x + 0.025, car.top - 0.05), shade(c, 0.55), -0.28)
    _front(cv, cam, car, (-0.01, 1.6, 0.01, car.top - 0.05), (20.0, 20.0, 20.0), -0.28)
    _front(cv, cam, car, (-1.22, car.top - 0.12, 1.22, car.top), shade(c, 0.8), -0.29)
    _front(cv, cam, car, (-1.45, car.beam_hi, 1.45, 1.55), (45.0, 48.0, 50.0), 0.0)
    del rng


def draw_end_fittings(
    cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator, buffers: bool
) -> float:
    """Buffer beam, coupler/buffers, brake hose and a ladder; returns the ladder side."""
    beam_c = shade(car.colour, 0.7) if rng.random() < 0.6 else (35.0, 36.0, 38.0)
    _front(cv, cam, car, (-1.5, car.beam_lo, 1.5, car.beam_hi), beam_c, 0.05)
    _front(cv, cam, car, (-1.5, car.beam_hi - 0.04, 1.5, car.beam_hi), shade(beam_c, 1.3), 0.06)
    dark = (30.0, 30.0, 32.0)
    if buffers:
        for sx in (-0.875, 0.875):
            _front(cv, cam, car, (sx - 0.14, 0.93, sx + 0.14, 1.2), dark, 0.25)
            cv.poly(
                cam.pts(circle3(car.xt + sx, 1.06, car.z0 - 0.45, 0.19, 28)),
                (70.0, 72.0, 75.0),
                car.z0 - 0.45,
            )
    _front(cv, cam, car, (-0.12, 0.95, 0.12, 1.15), dark, 0.3)
    _front(cv, cam, car, (-0.22, 0.9, 0.2, 1.22), (38.0, 40.0, 44.0), 0.55)
    hs = 1.0 if rng.random() < 0.5 else -1.0
    pts = [
        cam.p(car.xt + hs * x, y, car.z0 - 0.4)
        for x, y in ((0.35, 1.0), (0.4, 0.85), (0.42, 0.7), (0.3, 0.62))
    ]
    for a, b in zip(pts, pts[1:], strict=False):
        cv.line(a, b, (20.0, 22.0, 22.0), cam.scale(car.z0) * 0.06)
    ls = 1.0 if rng.random() < 0.5 else -1.0
    if car.kind != "flat":
        _ladder(cv, cam, car, ls)
    return ls


def _ladder(cv: Canvas, cam: Cam, car: Car, ls: float) -> None:
    c = shade(car.colour, 0.6)
    top = car.top - 0.2 if car.kind != "tank" else car.top - 0.5
    x0, x1 = ls * (car.half_w - 0.45), ls * (car.half_w - 0.1)
    th = cam.scale(car.z0) * 0.035
    for x in (x0, x1):
        cv.line(cam.p(car.xt + x, 0.7, car.z0 - 0.1), cam.p(car.xt + x, top, car.z0 - 0.1), c, th)
    for y in np.arange(0.8, top, 0.38):
        a = cam.p(car.xt + x0, float(y), car.z0 - 0.1)
        b = cam.p(car.xt + x1, float(y), car.z0 - 0.1)
        cv.line(a, b, c, th)


def draw_car(cv: Canvas, cam: Cam, car: Car, rng: np.random.Generator, sun: float) -> float:
    length = {"box": 14.0, "gondola": 13.0, "hopper": 12.0, "tank": 11.0, "flat": 13.5}[car.kind]
    draw_running_gear(cv, cam, car, length)
    draw_body_side(cv, cam, car, length, rng, sun)
    if car.kind == "box":
        draw_box_end(cv, cam, car, rng)
    elif car.kind == "gondola":
        draw_gondola_end(cv, cam, car, rng)
    elif car.kind == "hopper":
        draw_hopper_end(cv, cam, car, rng)
    elif car.kind == "tank":
        draw_tank(cv, cam, car, length, sun)
    else:
        draw_flat_end(cv, cam, car, rng)
    return draw_end_fittings(cv, cam, car, rng, rng.random() < 0.25)


def make_car(
    rng: np.random.Generator, kind: str, xt: float, z0: float, colour: Colour, side: float
) -> Car:
    top = {"box": 4.6, "gondola": 3.35, "hopper": 4.3, "tank": 4.2, "flat": 4.15}[kind]
    half = 1.6 if kind != "tank" else 1.55
    return Car(kind, xt, z0, half, top + rng.uniform(-0.1, 0.1), 0.92, 1.28, colour, side)
