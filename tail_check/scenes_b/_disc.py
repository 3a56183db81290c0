"""The tail signal disc: a red disc with a reflector, on a bracket at the end beam.

The disc is drawn frontally on its own square texture (high resolution, so a
small disc is still anti-aliased correctly) and warped onto a plane just in
front of the end wall, turned a little on its bracket, which is what makes it
elliptic in the image.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ._config import BGR, RANGES, FloatImage, FloatMap, Rng, hsv_to_bgr, uniform

TEXTURE_PX = 192
"""Side of the disc texture in pixels (the disc fills it)."""


@dataclass(frozen=True)
class DiscLook:
    """Appearance of one disc (BGR 0..255, fractions of the disc radius)."""

    field: BGR
    reflector: BGR
    rim: BGR | None
    rim_width: float
    reflector_radius: float
    dirt: float
    snow_clumps: int
    lit: bool


def choose_look(rng: Rng, *, snowy: bool, night: bool) -> DiscLook:
    """Random disc look: hue, fading and dirt, rim, reflector, snow clumps."""
    faded = rng.random() < 0.3
    hue = uniform(rng, (173.0, 184.0))
    sat = uniform(rng, (110.0, 175.0)) if faded else uniform(rng, (175.0, 250.0))
    val = uniform(rng, (120.0, 235.0))
    field = hsv_to_bgr(hue, sat, val)
    # the prismatic reflector reads brighter and a little less saturated than the paint
    reflector = hsv_to_bgr(hue + uniform(rng, (-3.0, 3.0)), sat * uniform(rng, (0.8, 0.95)),
                           min(255.0, val * uniform(rng, (1.15, 1.4)) + 20.0))
    rim: BGR | None = None
    draw = rng.random()
    if draw < RANGES.p_white_rim:
        rim = hsv_to_bgr(0.0, 0.0, uniform(rng, (190.0, 240.0)))
    elif draw < RANGES.p_white_rim + RANGES.p_dark_rim:
        rim = hsv_to_bgr(0.0, 0.0, uniform(rng, (15.0, 60.0)))
    clumps = 0
    if snowy and rng.random() < RANGES.p_snow_clump:
        clumps = int(rng.integers(1, 4))
    return DiscLook(
        field=field, reflector=reflector, rim=rim, rim_width=uniform(rng, (0.06, 0.14)),
        reflector_radius=uniform(rng, (0.22, 0.45)), dirt=uniform(rng, (0.0, 0.35)),
        snow_clumps=clumps, lit=night and rng.random() < 0.8,
    )


def render_disc(rng: Rng, look: DiscLook) -> tuple[FloatImage, FloatMap, FloatMap, FloatMap]:
    """Disc texture, its alpha, the reflector mask (for glow) and the full-disc mask.

    Returns
    -------
    texture : TEXTURE_PX² × 3 float32 BGR.
    alpha : TEXTURE_PX² float32 0..1, the visible disc (snow included).
    reflector : TEXTURE_PX² float32 0..1, the reflector area.
    full : TEXTURE_PX² float32 0..1, the whole disc outline (ground truth box).
    """
    size = TEXTURE_PX
    c = size / 2.0
    radius = size / 2.0 - 1.0
    tex = np.zeros((size, size, 3), np.float32)
    full = np.zeros((size, size), np.float32)
    centre = (int(c * 8), int(c * 8))
    cv2.circle(full, centre, int(radius * 8), 1.0, -1, cv2.LINE_AA, 3)
    inner = radius
    if look.rim is not None:
        cv2.circle(tex, centre, int(radius * 8), look.rim, -1, cv2.LINE_AA, 3)
        inner = radius * (1.0 - look.rim_width)
    cv2.circle(tex, centre, int(inner * 8), look.field, -1, cv2.LINE_AA, 3)
    refl = np.zeros((size, size), np.float32)
    r_refl = radius * look.reflector_radius
    cv2.circle(refl, centre, int(r_refl * 8), 1.0, -1, cv2.LINE_AA, 3)
    _reflector_texture(tex, refl, look.reflector, rng)
    _weather_disc(tex, look, rng)
    alpha = full.copy()
    for _ in range(look.snow_clumps):
        _snow_clump(tex, alpha, rng, radius)
    return tex, alpha, refl, full


def _reflector_texture(tex: FloatImage, refl: FloatMap, colour: BGR, rng: Rng) -> None:
    """Prismatic reflector: brighter red with a faint cell pattern and a rim."""
    size = tex.shape[0]
    ys, xs = np.mgrid[0:size, 0:size].astype(np.float32)
    cell = uniform(rng, (5.0, 9.0))
    pattern = 0.9 + 0.1 * np.cos(xs * 2 * np.pi / cell) * np.cos(ys * 2 * np.pi / cell)
    col = np.asarray(colour, np.float32) * pattern[..., None]
    a = refl[..., None]
    tex[:] = tex * (1.0 - a) + col * a
    edge = cv2.morphologyEx(refl, cv2.MORPH_GRADIENT, np.ones((3, 3), np.uint8))
    tex *= (1.0 - 0.35 * edge)[..., None]


def _weather_disc(tex: FloatImage, look: DiscLook, rng: Rng) -> None:
    """Dirt (darker lower half, blotches) and uneven fading."""
    size = tex.shape[0]
    ys = np.linspace(0.0, 1.0, size, dtype=np.float32)[:, None]
    small = rng.standard_normal((6, 6)).astype(np.float32)
    blotch = cv2.resize(small, (size, size), interpolation=cv2.INTER_CUBIC)
    factor = 1.0 - look.dirt * (0.6 * ys + 0.4 * np.clip(blotch, 0.0, 2.0) / 2.0)
    tex *= np.clip(factor, 0.3, 1.0)[..., None]


def _snow_clump(tex: FloatImage, alpha: FloatMap, rng: Rng, radius: float) -> None:
    """A white clump of snow stuck to the disc, sometimes overhanging its edge."""
    size = tex.shape[0]
    angle = uniform(rng, (0.0, 2.0 * np.pi))
    dist = radius * uniform(rng, (0.2, 0.95))
    cx = size / 2.0 + dist * np.cos(angle)
    cy = size / 2.0 + dist * np.sin(angle)
    mask = np.zeros((size, size), np.float32)
    for _ in range(5):
        ox, oy = rng.normal(0.0, radius * 0.12, 2)
        r = radius * uniform(rng, (0.1, 0.25))
        cv2.circle(mask, (int((cx + ox) * 8), int((cy + oy) * 8)), int(r * 8), 1.0, -1,
                   cv2.LINE_AA, 3)
    white = np.float32(uniform(rng, (200.0, 245.0)))
    tex[:] = tex * (1.0 - mask[..., None]) + white * mask[..., None]
    alpha[:] = np.maximum(alpha, mask)
