"""Light and weather per condition: sky, ambient light, sun shading, headlights, fog.

The painted albedo is lit as ``albedo · shade · ambient · tint`` plus a
headlight term that falls off with depth, then emission (lamps, lit
reflectors) is added, then fog blends toward the fog colour by depth.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ._camera import Canvas
from ._config import BGR, FloatImage, Rng, f32, hsv_to_bgr, uniform


@dataclass(frozen=True)
class Light:
    """Lighting of one scene (BGR 0..255 colours, factors, metres).

    ``side_shade`` multiplies the side wall relative to the end wall (the sun
    lights one face more); ``visibility`` is the fog e-folding distance;
    ``headlight`` the power of a lamp at the camera (0 = none).
    """

    sky_top: BGR
    sky_bottom: BGR
    verge: BGR
    tree: BGR
    ambient: float
    tint: BGR
    side_shade: float
    visibility: float
    fog: BGR
    headlight: float
    precipitation: str
    snowy: bool


def _verge(rng: Rng, snowy: bool) -> BGR:
    if snowy:
        return hsv_to_bgr(110.0, uniform(rng, (0.0, 20.0)), uniform(rng, (200.0, 240.0)))
    if rng.random() < 0.6:
        return hsv_to_bgr(uniform(rng, (30.0, 50.0)), uniform(rng, (60.0, 150.0)),
                          uniform(rng, (70.0, 140.0)))
    return hsv_to_bgr(uniform(rng, (10.0, 25.0)), uniform(rng, (40.0, 110.0)),
                      uniform(rng, (70.0, 130.0)))


def choose_light(rng: Rng, condition: str) -> Light:
    """Random light for ``condition`` (one of CONDITIONS)."""
    grey = uniform(rng, (150.0, 215.0))
    snowy = condition == "snow" or (condition in ("fog", "overcast") and rng.random() < 0.2)
    base = {
        "daylight": ((205.0, 150.0, 90.0), (235.0, 215.0, 190.0), 1.0, 0.6, 3000.0, 0.0),
        "overcast": ((grey, grey, grey - 8), (grey + 20, grey + 20, grey + 15), 0.8, 0.88,
                     1500.0, 0.0),
        "dusk": ((120.0, 70.0, 50.0), (110.0, 150.0, 215.0), 0.35, 0.8, 900.0, 0.25),
        "night": ((22.0, 12.0, 8.0), (40.0, 35.0, 35.0), 0.07, 0.9, 700.0, 1.0),
        "rain": ((grey - 40,) * 3, (grey - 15,) * 3, 0.6, 0.9, 300.0, 0.0),
        "snow": ((grey + 10,) * 3, (grey + 25,) * 3, 0.95, 0.88, 250.0, 0.0),
        "fog": ((205.0, 205.0, 200.0), (215.0, 215.0, 212.0), 0.8, 0.92, 60.0, 0.0),
    }[condition]
    top, bottom, ambient, side, vis, head = base
    tint = (1.0, 1.0, 1.0)
    if condition == "dusk":
        tint = (uniform(rng, (0.8, 1.1)), uniform(rng, (0.85, 1.0)), uniform(rng, (0.9, 1.15)))
    elif condition == "night":
        tint = (0.55, 0.8, 1.1) if rng.random() < 0.5 else (1.0, 0.95, 0.9)
    fog_col = tuple(float(c) * (0.35 if condition == "night" else 1.0) for c in bottom)
    return Light(
        sky_top=top, sky_bottom=bottom, verge=_verge(rng, snowy),
        tree=hsv_to_bgr(uniform(rng, (35.0, 75.0)), uniform(rng, (60.0, 160.0)),
                        uniform(rng, (40.0, 100.0))),
        ambient=ambient * uniform(rng, (0.8, 1.2)), tint=tint,
        side_shade=side * uniform(rng, (0.9, 1.1)) if rng.random() < 0.5 else 1.0 / side,
        visibility=vis * uniform(rng, (0.4, 1.6)),
        fog=(fog_col[0], fog_col[1], fog_col[2]),
        headlight=head * uniform(rng, (0.5, 1.5)) if head > 0 and rng.random() < 0.85 else 0.0,
        precipitation=condition if condition in ("rain", "snow") else "none", snowy=snowy,
    )


def light_scene(canvas: Canvas, light: Light, rng: Rng) -> FloatImage:
    """Lit float image of the canvas (BGR, 0..255 nominal, may exceed)."""
    h, w = canvas.height, canvas.width
    tint = np.asarray(light.tint, np.float32)
    lit = canvas.albedo * (canvas.shade * light.ambient)[..., None] * tint
    if light.headlight > 0:
        ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
        cx, cy = w * uniform(rng, (0.3, 0.7)), h * uniform(rng, (0.5, 0.8))
        cone = np.exp(-(((xs - cx) / (0.5 * w)) ** 2 + ((ys - cy) / (0.45 * h)) ** 2))
        depth = np.minimum(canvas.depth, 1e4)
        reach = uniform(rng, (10.0, 30.0))
        fall = light.headlight / (1.0 + (depth / reach) ** 2)
        lit = lit + canvas.albedo * (cone * fall)[..., None] * np.float32(0.9)
    glare, halo = uniform(rng, (0.006, 0.02)), uniform(rng, (0.3, 1.2))
    emits = bool(canvas.emission.max() > 0)
    if emits:  # lamps and lit reflectors: core plus glare (skipped when nothing shines)
        lit = lit + canvas.emission
        lit = lit + cv2.GaussianBlur(canvas.emission, (0, 0), max(1.0, h * glare)) * halo
    trans = np.exp(-np.minimum(canvas.depth, 1e5) / light.visibility)[..., None]
    fog = np.asarray(light.fog, np.float32) * (light.ambient if light.headlight > 0 else 1.0)
    if emits and light.visibility < 200.0:  # thick fog scatters lamp light into wide halos
        lit = lit + cv2.GaussianBlur(canvas.emission, (0, 0), h * 0.04) * np.float32(0.8)
    lit = f32(lit * trans + fog * (1.0 - trans))
    return f32(lit)


def precipitation(image: FloatImage, light: Light, rng: Rng) -> FloatImage:
    """Rain streaks or snowflakes in front of everything."""
    if light.precipitation == "none":
        return image
    h, w = image.shape[:2]
    layer = np.zeros((h, w), np.float32)
    if light.precipitation == "rain":
        slant = uniform(rng, (-0.25, 0.25))
        for _ in range(int(w * h / 2500 * uniform(rng, (0.3, 1.0)))):
            x, y = float(rng.uniform(0, w)), float(rng.uniform(0, h))
            length = float(rng.uniform(0.02, 0.06)) * h
            end = (int(x + slant * length), int(y + length))
            cv2.line(layer, (int(x), int(y)), end, float(rng.uniform(0.1, 0.35)), 1, cv2.LINE_AA)
        layer = f32(cv2.GaussianBlur(layer, (3, 3), 0))
        return f32(image * (1.0 - layer[..., None] * 0.5) + 200.0 * layer[..., None])
    for _ in range(int(w * h / 1500 * uniform(rng, (0.2, 1.0)))):
        r = float(rng.pareto(2.5) + 1.0) * h * 0.0012
        centre = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
        cv2.circle(layer, centre, max(1, int(r)), float(rng.uniform(0.4, 1.0)), -1, cv2.LINE_AA)
    layer = f32(cv2.GaussianBlur(layer, (0, 0), 1.0))
    return f32(image * (1.0 - layer[..., None]) + 235.0 * layer[..., None])
