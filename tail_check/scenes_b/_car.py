"""The last car: paint, shape and the two visible faces (end wall and side wall).

1520 mm freight cars have a centre automatic coupler and no side buffers; the
end beam (buffer beam) spans the car at 0.85–1.30 m above rail top, and the
tail disc hangs on a bracket at its right end. A few cars get side buffers
(other gauges) because round dark buffer heads are a useful shape confuser.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ._config import BGR, CAR_PAINTS, CAR_SHAPES, RANGES, Rng, hsv_to_bgr, uniform
from ._face import Face

BEAM_BOTTOM = 0.85
BEAM_TOP = 1.30
COUPLER_Y = 1.06
WHEEL_RADIUS = 0.475
"""Metres above rail top: end beam, coupler axis, wheel radius."""

BODY_TOP = {"box": 4.7, "gondola": 3.5, "tank": 4.2, "hopper": 4.4, "flat": 1.42}


@dataclass(frozen=True)
class CarSpec:
    """Geometry and paint of the last car (metres, BGR 0..255)."""

    shape: str
    paint: str
    colour: BGR
    beam_colour: BGR
    width: float
    length: float
    top: float
    container: BGR | None
    buffers: bool
    ribs: int


def paint_colour(rng: Rng, paint: str) -> BGR:
    """One shade of a paint family (OpenCV HSV ranges)."""
    ranges = {
        "red_brown": ((0, 10), (110, 210), (70, 160)),
        "dark_red": ((172, 182), (130, 230), (45, 110)),
        "bright_red": ((175, 184), (190, 250), (160, 235)),
        "rusty": ((6, 16), (120, 200), (70, 140)),
        "green": ((50, 82), (50, 160), (45, 130)),
        "blue": ((98, 122), (70, 180), (55, 150)),
        "grey": ((0, 180), (0, 25), (85, 185)),
        "black_tank": ((0, 180), (0, 30), (18, 50)),
        "silver": ((0, 180), (0, 15), (175, 225)),
    }
    hue, sat, val = ranges[paint]
    return hsv_to_bgr(uniform(rng, hue), uniform(rng, sat), uniform(rng, val))


def choose_car(rng: Rng, *, red_body: bool) -> CarSpec:
    """Random car; ``red_body`` forces a red or red-brown paint."""
    shape = CAR_SHAPES[int(rng.integers(len(CAR_SHAPES)))]
    reds = ("red_brown", "dark_red", "bright_red", "rusty")
    paints = reds if red_body else CAR_PAINTS
    paint = paints[int(rng.integers(len(paints)))]
    if shape == "tank" and rng.random() < 0.4 and not red_body:
        paint = "black_tank"
    colour = paint_colour(rng, paint)
    beam = colour if rng.random() < 0.5 else paint_colour(rng, "black_tank")
    container = None
    if shape == "flat" and rng.random() < 0.6:
        container = paint_colour(rng, CAR_PAINTS[int(rng.integers(len(CAR_PAINTS)))])
    return CarSpec(
        shape=shape, paint=paint, colour=colour, beam_colour=beam,
        width=3.0 if shape == "tank" else uniform(rng, (3.05, 3.25)),
        length=uniform(rng, (12.0, 19.0)), top=BODY_TOP[shape] * uniform(rng, (0.96, 1.04)),
        container=container, buffers=bool(rng.random() < 0.2), ribs=int(rng.integers(3, 9)),
    )


def rust(face: Face, rng: Rng, amount: float) -> None:
    """Rust patches and streaks: noise above a threshold, blended towards rust brown."""
    h, w = face.alpha.shape
    cells = (max(2, int(h / (0.5 * face.ppm)) + 1), max(2, int(w / (0.5 * face.ppm)) + 1))
    small = rng.standard_normal(cells).astype(np.float32)
    big = cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)
    streaks = cv2.resize(rng.standard_normal((2, max(2, w // 6))).astype(np.float32), (w, h))
    level = big + 0.3 * streaks
    cover = np.clip((level - (1.6 - amount)) * 2.0, 0.0, 0.85)[..., None]
    colour = np.asarray(hsv_to_bgr(uniform(rng, (8.0, 16.0)), uniform(rng, (150.0, 220.0)),
                                   uniform(rng, (60.0, 120.0))), np.float32)
    face.texture[:] = face.texture * (1.0 - cover) + colour * cover


def _scaled(colour: BGR, factor: float) -> BGR:
    return (colour[0] * factor, colour[1] * factor, colour[2] * factor)


def _end_body(face: Face, car: CarSpec, rng: Rng) -> None:
    """End wall above the beam, by car shape."""
    half = car.width / 2.0
    col = car.colour
    if car.shape == "tank":
        face.rect(-half + 0.2, BEAM_TOP, half - 0.2, BEAM_TOP + 0.25, car.beam_colour)
        centre = BEAM_TOP + 0.25 + 1.45
        for k in range(8, 0, -1):  # dished tank head, brighter at the middle
            r = 1.45 * k / 8.0
            face.ellipse(0.0, centre, r, r, _scaled(col, 1.0 + 0.05 * (8 - k) / 8.0))
        face.line((0.9, BEAM_TOP), (0.9, centre + 1.2), _scaled(col, 0.6), 0.05)
        return
    if car.shape == "flat":
        face.rect(-half, BEAM_TOP - 0.1, half, car.top, _scaled(col, 0.9))
        if car.container is not None:
            face.rect(-1.22, car.top, 1.22, car.top + 2.59, car.container)
            for k in range(1, 12):
                u = -1.22 + 2.44 * k / 12.0
                face.line((u, car.top + 0.1), (u, car.top + 2.5), _scaled(car.container, 0.8), 0.03)
        return
    face.rect(-half, BEAM_TOP, half, car.top, col)
    rib = _scaled(col, uniform(rng, (0.7, 0.85)))
    for k in range(1, car.ribs):  # end-wall stiffeners
        if car.shape == "gondola":
            y = BEAM_TOP + (car.top - BEAM_TOP) * k / car.ribs
            face.line((-half, y), (half, y), rib, 0.08)
        else:
            u = -half + car.width * k / car.ribs
            face.line((u, BEAM_TOP), (u, car.top), rib, 0.07)
    if car.shape == "hopper":
        face.line((-half, BEAM_TOP + 0.3), (half, car.top - 0.4), rib, 0.1)
        face.line((half, BEAM_TOP + 0.3), (-half, car.top - 0.4), rib, 0.1)
    face.rect(-half, car.top - 0.12, half, car.top, _scaled(col, 0.8))
    for s in (-1.0, 1.0):  # corner posts
        face.rect(s * half - 0.08, BEAM_TOP, s * half + 0.08, car.top, _scaled(col, 0.75))


def draw_end(face: Face, car: CarSpec, rng: Rng) -> None:
    """End wall: underframe and bogie end, beam, coupler, body by shape."""
    half = car.width / 2.0
    dark = (30.0, 32.0, 36.0)
    face.rect(-1.25, 0.15, 1.25, BEAM_BOTTOM, dark, alpha=0.9)
    for s in (-1.0, 1.0):
        face.ellipse(s * 0.79, WHEEL_RADIUS, 0.06, WHEEL_RADIUS, (20.0, 20.0, 22.0))
    face.rect(-half, BEAM_BOTTOM, half, BEAM_TOP, car.beam_colour)
    face.rect(-0.22, COUPLER_Y - 0.17, 0.22, COUPLER_Y + 0.15, (38.0, 40.0, 44.0))
    face.rect(-0.14, COUPLER_Y - 0.1, 0.14, COUPLER_Y + 0.08, (60.0, 62.0, 66.0))
    face.line((-1.3, BEAM_TOP + 0.05), (0.2, BEAM_TOP + 0.05), (50.0, 50.0, 50.0), 0.03)
    if car.buffers:
        for s in (-1.0, 1.0):
            face.rect(s * 0.875 - 0.12, COUPLER_Y - 0.12, s * 0.875 + 0.12, COUPLER_Y + 0.12, dark)
            face.ellipse(s * 0.875, COUPLER_Y, 0.2, 0.2, (55.0, 58.0, 62.0))
    _end_body(face, car, rng)
    if car.paint == "rusty" or rng.random() < RANGES.p_rust:
        rust(face, rng, uniform(rng, (0.1, 0.8)))
    face.grime(rng, uniform(rng, (0.05, 0.3)), 0.4)
    face.shade_rows(BEAM_TOP + 1.0, 0.0, uniform(rng, (0.1, 0.45)))


def _bogie(face: Face, centre: float) -> None:
    """Two-axle bogie seen from the side, centred at plane coordinate ``centre``."""
    frame = (35.0, 37.0, 40.0)
    face.rect(centre - 1.35, 0.35, centre + 1.35, 0.85, frame)
    for axle in (-0.925, 0.925):
        face.ellipse(centre + axle, WHEEL_RADIUS, WHEEL_RADIUS, WHEEL_RADIUS, (28.0, 28.0, 30.0))
        face.ellipse(centre + axle, WHEEL_RADIUS, 0.12, 0.12, (70.0, 72.0, 75.0))


def draw_side(face: Face, car: CarSpec, rng: Rng) -> None:
    """Side wall: body by shape, sole bar, bogies, hopper chutes."""
    length, col = car.length, car.colour
    for centre in (1.9, length - 1.9):
        _bogie(face, centre)
    face.rect(0.0, BEAM_BOTTOM + 0.05, length, BEAM_TOP, car.beam_colour)
    if car.shape == "tank":
        rows = 24
        for k in range(rows):  # cylinder shading: brightest a third from the top
            y0 = BEAM_TOP + 0.2 + 2.8 * k / rows
            light = 0.55 + 0.55 * np.cos((k / rows - 0.65) * np.pi * 0.9)
            face.rect(0.2, y0, length - 0.2, y0 + 2.8 / rows + 0.01, _scaled(col, light))
    elif car.shape == "flat":
        face.rect(0.0, BEAM_TOP - 0.1, length, car.top, _scaled(col, 0.9))
        if car.container is not None:
            face.rect(0.3, car.top, min(length - 0.3, 12.5), car.top + 2.59, car.container)
    else:
        face.rect(0.0, BEAM_TOP, length, car.top, col)
        rib = _scaled(col, uniform(rng, (0.65, 0.85)))
        step = uniform(rng, (0.9, 1.6))
        for u in np.arange(step, length, step):
            face.line((float(u), BEAM_TOP), (float(u), car.top), rib, 0.09)
        if car.shape == "hopper":
            for centre in (length * 0.35, length * 0.65):
                face.poly([(centre - 1.6, BEAM_TOP), (centre + 1.6, BEAM_TOP),
                           (centre + 0.5, 0.6), (centre - 0.5, 0.6)], _scaled(col, 0.8))
    if car.paint == "rusty" or rng.random() < RANGES.p_rust:
        rust(face, rng, uniform(rng, (0.1, 0.8)))
    face.grime(rng, uniform(rng, (0.05, 0.3)), 0.6)
    face.shade_rows(BEAM_TOP + 1.2, 0.0, uniform(rng, (0.1, 0.4)))
