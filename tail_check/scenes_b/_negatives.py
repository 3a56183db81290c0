"""Hard negatives: red things on and around the car that are not a tail disc.

Painted ones (lettering, stripes, logos, hand wheels) go onto the car's face
textures so they share its perspective; lamps and trackside objects are placed
in the world and projected.
"""

from __future__ import annotations

import cv2
import numpy as np

from ._camera import Camera, Canvas
from ._car import BEAM_TOP, CarSpec
from ._config import BGR, Rng, hsv_to_bgr, uniform
from ._face import Face

BOWL_TEXT = ("DPO", "BOP", "ROD", "0869", "PD", "OBO", "DB", "P8", "6090", "RDB", "DOP", "B09")
"""Strings of letters with closed bowls (D, P, O, Р≈P, B, 0, 6, 8, 9)."""

FONTS = (cv2.FONT_HERSHEY_SIMPLEX, cv2.FONT_HERSHEY_DUPLEX, cv2.FONT_HERSHEY_TRIPLEX)


def red_paint(rng: Rng) -> BGR:
    """A red paint for lettering, stripes and logos (as saturated as a disc)."""
    return hsv_to_bgr(uniform(rng, (172.0, 186.0)), uniform(rng, (160.0, 250.0)),
                      uniform(rng, (130.0, 235.0)))


def red_lettering(face: Face, car: CarSpec, rng: Rng, height_m: float, tail_u: float) -> None:
    """Red letters with closed bowls, mid-body, near the tail end of the face."""
    label = BOWL_TEXT[int(rng.integers(len(BOWL_TEXT)))]
    font = FONTS[int(rng.integers(len(FONTS)))]
    weight = uniform(rng, (0.1, 0.2))
    width = face.text_width(label, height_m, font, weight)
    low = BEAM_TOP + 0.15
    high = max(low + 0.01, min(car.top, face.top) - height_m - 0.1)
    y = uniform(rng, (low, high))
    span = face.width_m - width - 0.2
    start = tail_u + 0.3 if tail_u < face.width_m / 2 else tail_u - width - 0.3
    if face.width_m < 4.0:
        start = face.u0 + uniform(rng, (0.1, max(0.11, span)))
    face.text(start, y, label, height_m, red_paint(rng), font, weight)


def red_stripe(face: Face, car: CarSpec, rng: Rng, y: float | None = None) -> None:
    """A horizontal (sometimes diagonal) red band along the face."""
    band = uniform(rng, (0.12, 0.45))
    if y is None:
        y = uniform(rng, (BEAM_TOP + 0.3, max(BEAM_TOP + 0.4, car.top - band - 0.2)))
    colour = red_paint(rng)
    u0, u1 = face.u0, face.u0 + face.width_m
    if face.width_m > 4.0 and rng.random() < 0.3:
        mid = u0 + face.width_m * uniform(rng, (0.3, 0.7))
        face.poly([(mid - 1.2, BEAM_TOP + 0.2), (mid, BEAM_TOP + 0.2), (mid + 1.8, car.top),
                   (mid + 0.6, car.top)], colour)
    else:
        face.rect(u0, y, u1, y + band, colour)


def red_logo(face: Face, car: CarSpec, rng: Rng, size_m: float, tail_u: float) -> None:
    """A red company logo: a round emblem or a slanted box with white letters."""
    colour = red_paint(rng)
    white = hsv_to_bgr(0.0, 0.0, uniform(rng, (200.0, 245.0)))
    u = tail_u + (1.0 if tail_u < face.width_m / 2 else -1.0) * (size_m + 0.4)
    if face.width_m < 4.0:
        u = face.u0 + face.width_m * uniform(rng, (0.3, 0.7))
    y = uniform(rng, (BEAM_TOP + size_m + 0.2, max(BEAM_TOP + size_m + 0.3, car.top - size_m)))
    if rng.random() < 0.5:
        face.ellipse(u, y, size_m / 2, size_m / 2, colour)
        face.ellipse(u, y, size_m * 0.32, size_m * 0.32, white, thickness_m=size_m * 0.08)
        face.line((u - size_m * 0.2, y), (u + size_m * 0.2, y), white, size_m * 0.08)
        return
    h = size_m * 0.6
    face.poly([(u - size_m, y - h / 2), (u + size_m * 0.8, y - h / 2),
               (u + size_m, y + h / 2), (u - size_m * 0.8, y + h / 2)], colour)
    face.text(u - size_m * 0.6, y - h * 0.3, "PZD", h * 0.6, white, cv2.FONT_HERSHEY_DUPLEX)


def hand_wheel(face: Face, car: CarSpec, rng: Rng, side: float) -> None:
    """A red brake hand wheel with spokes on the end wall (or end platform)."""
    r = uniform(rng, (0.18, 0.3))
    u = side * uniform(rng, (0.6, car.width / 2 - r - 0.05))
    y = uniform(rng, (BEAM_TOP + r + 0.1, min(car.top, BEAM_TOP + 2.2) - r))
    colour = red_paint(rng)
    rim = r * uniform(rng, (0.12, 0.2))
    face.line((u, BEAM_TOP), (u, y), (45.0, 45.0, 48.0), 0.05)  # brake staff
    face.ellipse(u, y, r, r, colour, thickness_m=rim)
    spokes = int(rng.integers(3, 7))
    phase = uniform(rng, (0.0, np.pi))
    for k in range(spokes):
        a = phase + np.pi * 2 * k / spokes
        face.line((u, y), (u + r * np.cos(a), y + r * np.sin(a)), colour, rim * 0.7)
    face.ellipse(u, y, r * 0.18, r * 0.18, colour)


def lamp_glow(canvas: Canvas, centre: tuple[float, float], radius: float, colour: BGR,
              power: float) -> None:
    """Add a lit lamp: a bright core and a soft halo to the emission buffer."""
    h, w = canvas.height, canvas.width
    reach = int(max(3.0, radius * 6.0))
    cx, cy = int(round(centre[0])), int(round(centre[1]))
    x0, x1, y0, y1 = max(0, cx - reach), min(w, cx + reach), max(0, cy - reach), min(h, cy + reach)
    if x0 >= x1 or y0 >= y1:
        return
    ys, xs = np.mgrid[y0:y1, x0:x1].astype(np.float32)
    d = np.hypot(xs - centre[0], ys - centre[1]) / max(radius, 0.7)
    core = np.clip(1.5 - d, 0.0, 1.0)
    halo = 0.35 * np.exp(-0.5 * (d / 2.2) ** 2)
    light = (core + halo)[..., None] * np.asarray(colour, np.float32) * power
    canvas.emission[y0:y1, x0:x1] += light.astype(np.float32)


def tail_lamps(canvas: Canvas, camera: Camera, car: CarSpec, z: float, rng: Rng) -> None:
    """Two red electric tail lamps (loco / coach style) on the end wall."""
    y = BEAM_TOP + uniform(rng, (0.1, 0.9))
    r = uniform(rng, (0.05, 0.1))
    colour = hsv_to_bgr(uniform(rng, (174.0, 182.0)), uniform(rng, (150.0, 230.0)), 255.0)
    for s in (-1.0, 1.0):
        point = (s * (car.width / 2 - 0.35), y, z - 0.05)
        u, v = camera.project(np.asarray([point]))[0]
        radius = camera.focal * r / max(camera.depth(point), 0.5)
        lamp_glow(canvas, (float(u), float(v)), radius, colour, uniform(rng, (0.8, 1.6)))


def signal_light(canvas: Canvas, camera: Camera, rng: Rng, z_end: float) -> None:
    """A colour-light signal at trackside showing red: mast, dark head, lit lamp."""
    side = 1.0 if rng.random() < 0.5 else -1.0
    x = side * uniform(rng, (2.6, 4.5))
    z = uniform(rng, (max(6.0, z_end * 0.4), z_end * 1.8 + 15.0))
    height = uniform(rng, (2.5, 5.5))
    depth = max(camera.depth((x, height, z)), 1.0)
    mast = np.asarray([(x - 0.08, 0.0, z), (x + 0.08, 0.0, z), (x + 0.08, height, z),
                       (x - 0.08, height, z)])
    canvas.paint_polygon(camera.project_polygon(mast), (60.0, 62.0, 65.0), depth)
    head = np.asarray([(x - 0.2, height, z), (x + 0.2, height, z), (x + 0.2, height + 1.0, z),
                       (x - 0.2, height + 1.0, z)])
    canvas.paint_polygon(camera.project_polygon(head), (18.0, 18.0, 20.0), depth)
    lamp = (x, height + 0.3 + 0.4 * float(rng.integers(2)), z - 0.05)
    u, v = camera.project(np.asarray([lamp]))[0]
    colour = hsv_to_bgr(uniform(rng, (174.0, 184.0)), uniform(rng, (170.0, 240.0)), 255.0)
    lamp_glow(canvas, (float(u), float(v)), camera.focal * 0.07 / depth, colour,
              uniform(rng, (0.8, 1.8)))


def red_barrier(canvas: Canvas, camera: Camera, rng: Rng, z_end: float) -> None:
    """A red-and-white barrier boom (level crossing / depot gate) across the view."""
    z = uniform(rng, (4.0, z_end * 1.5 + 10.0)) if z_end > 6 else z_end + 5.0
    y = uniform(rng, (0.8, 1.2))
    x0 = (1.0 if rng.random() < 0.5 else -1.0) * uniform(rng, (3.0, 5.0))
    x1 = -x0 * uniform(rng, (0.2, 1.0))
    segments = int(rng.integers(6, 12))
    red, white = red_paint(rng), hsv_to_bgr(0.0, 0.0, 230.0)
    depth = max(camera.depth((0.0, y, z)), 1.0)
    for k in range(segments):
        a = x0 + (x1 - x0) * k / segments
        b = x0 + (x1 - x0) * (k + 1) / segments
        quad = np.asarray([(a, y, z), (b, y, z), (b, y + 0.12, z), (a, y + 0.12, z)])
        canvas.paint_polygon(camera.project_polygon(quad), red if k % 2 == 0 else white, depth)
    post = np.asarray([(x0 - 0.15, 0.0, z), (x0 + 0.15, 0.0, z), (x0 + 0.15, y + 0.3, z),
                       (x0 - 0.15, y + 0.3, z)])
    canvas.paint_polygon(camera.project_polygon(post), red, depth)
