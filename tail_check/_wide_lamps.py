"""Lamps for the domain-randomised generator A: small bright red lights that are no disc.

A verifier trained without them learns "small, round, red and bright" means a disc
(issue 11: electric tail lamps, signals and a road vehicle's lights were called
``present``). Three kinds, lit or dark, by day and by night:

* ``tail_lamp`` — an electric tail lamp (or a pair) on the car's end, round or square,
  in a dark bezel, at the buffer beam's corners or high on the end wall: the same place
  and about the size of a small disc;
* ``signal_head`` — a trackside signal: a black head on a post with two or three lenses,
  one of them lit (red, or yellow/green beside a dark red one);
* ``road_tail_lights`` — a road vehicle's rear at a level crossing, two lit red lights.

Each lamp is drawn in two steps: the housing and the dark lens are painted with the
scene (:func:`draw_lamp`, before the scene is lit), the light a lit lens emits is added
after the lighting (:func:`emit`), so a lit lamp is bright at night and saturates the
sensor towards white at its core, as real lamps do.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass

import cv2
import numpy as np

from ._scene import CarGeometry, FloatImage

__all__ = ["LAMP_KINDS", "LAMPS", "Emitter", "LampRanges", "draw_lamp", "emit"]

Range = tuple[float, float]
LAMP_KINDS = ("tail_lamp", "signal_head", "road_tail_lights")


@dataclass(frozen=True)
class LampRanges:
    """Ranges of the lamps (lengths as fractions of the car width unless stated).

    Attributes
    ----------
    lamp_radius : tail lamp lens radius. A lens is 0.1-0.17 m across on a car end about
        3 m wide (radius up to about 0.028 of the width), smaller than a tail disc
        (0.032-0.07 in :class:`~tail_check._wide_draw.WideRanges`): a red lamp as large
        as a disc, drawn dark, is a disc without its reflector to any eye, and as a
        "negative" it alone set the ``present`` threshold above every disc.
    lit_share : share of tail lamps and road lights that are lit (by day and night).
    pair_share : share of tail lamps drawn as a pair at both corners.
    square_share : share of square lenses.
    high_share : share of tail lamps high on the end wall instead of at the beam.
    bezel : dark bezel width, in lens radii.
    lens_hue, lens_sat, dark_val : a lens's red (hue in degrees) and an unlit lens's
        value (0..1).
    gain : emitted light of a lit lens, in units of full scale (above 1 it clips).
    bloom : halo sigma, in lens radii (lens flare and JPEG spread).
    halo : strength of the halo relative to the lens.
    signal_lens : signal lens radius, fraction of the image width.
    signal_red_share : share of signals showing red (the rest a yellow or green one,
        with an unlit red lens beside it).
    road_width : width of the road vehicle's rear, fraction of the image width.
    """

    lamp_radius: Range = (0.01, 0.028)
    lit_share: float = 0.75
    pair_share: float = 0.55
    square_share: float = 0.3
    high_share: float = 0.3
    bezel: Range = (0.15, 0.5)
    lens_hue: Range = (-10.0, 14.0)
    lens_sat: Range = (0.6, 1.0)
    dark_val: Range = (0.2, 0.55)
    gain: Range = (0.9, 4.0)
    bloom: Range = (0.4, 2.5)
    halo: Range = (0.15, 0.7)
    signal_lens: Range = (0.004, 0.014)
    signal_red_share: float = 0.7
    road_width: Range = (0.08, 0.2)


LAMPS = LampRanges()


@dataclass(frozen=True)
class Emitter:
    """A lit lens: where it is (filled shape), its colour (RGB 0..1) and light."""

    centre: tuple[int, int]
    size: tuple[int, int]
    """Half-width and half-height in pixels."""
    square: bool
    colour: tuple[float, float, float]
    gain: float
    bloom: float
    halo: float


def _red(rng: np.random.Generator, c: LampRanges, val: float) -> tuple[float, float, float]:
    r, g, b = colorsys.hsv_to_rgb(
        (rng.uniform(*c.lens_hue) % 360) / 360, rng.uniform(*c.lens_sat), val
    )
    return (float(r), float(g), float(b))


def _lens(
    rng: np.random.Generator,
    img: FloatImage,
    centre: tuple[int, int],
    r: int,
    square: bool,
    lit: bool,
    colour: tuple[float, float, float],
    c: LampRanges,
) -> Emitter | None:
    """Bezel and lens (dark, or the lens colour if lit); the emitter when lit."""
    x, y = centre
    bezel = max(1, int(round(r * rng.uniform(*c.bezel))))
    housing = (float(rng.uniform(0.03, 0.12)),) * 3
    if square:
        cv2.rectangle(
            img, (x - r - bezel, y - r - bezel), (x + r + bezel, y + r + bezel), housing, -1
        )
        cv2.rectangle(img, (x - r, y - r), (x + r, y + r), colour, -1)
    else:
        cv2.circle(img, (x, y), r + bezel, housing, -1, cv2.LINE_AA)
        cv2.circle(img, (x, y), r, colour, -1, cv2.LINE_AA)
    if not lit:
        return None
    return Emitter(
        (x, y),
        (r, r),
        square,
        colour,
        float(rng.uniform(*c.gain)),
        float(r * rng.uniform(*c.bloom)),
        float(rng.uniform(*c.halo)),
    )


def _tail_lamps(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, c: LampRanges
) -> list[Emitter]:
    r = max(1, int(geo.width * rng.uniform(*c.lamp_radius)))
    lit = bool(rng.random() < c.lit_share)
    square = bool(rng.random() < c.square_share)
    inset = geo.width * rng.uniform(0.05, 0.2)
    if rng.random() < c.high_share:
        y = int(geo.top + (geo.beam_top - geo.top) * rng.uniform(0.08, 0.3))
    else:
        y = int(geo.beam_top - r * rng.uniform(1.2, 3.0))
    sides = [geo.left + inset, geo.right - inset]
    if rng.random() >= c.pair_share:
        sides = [sides[int(rng.integers(2))]]
    val = 1.0 if lit else float(rng.uniform(*c.dark_val))
    colour = _red(rng, c, val)
    out = [_lens(rng, img, (int(x), y), r, square, lit, colour, c) for x in sides]
    return [e for e in out if e is not None]


def _signal(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, c: LampRanges
) -> list[Emitter]:
    h, w = img.shape[:2]
    r = max(1, int(w * rng.uniform(*c.signal_lens)))
    # beside the car, not on it: left or right of the body when there is room
    room = [x for x in (geo.left - 4 * r, geo.right + 4 * r) if 3 * r < x < w - 3 * r]
    x = int(room[int(rng.integers(len(room)))] if room else rng.uniform(3 * r, w - 3 * r))
    n = int(rng.integers(2, 4))
    top = int(h * rng.uniform(0.05, 0.45))
    pitch = int(2.6 * r)
    post = (float(rng.uniform(0.15, 0.35)),) * 3
    cv2.rectangle(img, (x - max(1, r // 2), top), (x + max(1, r // 2), h), post, -1)
    cv2.rectangle(
        img,
        (x - int(1.6 * r), top - pitch // 2),
        (x + int(1.6 * r), top + n * pitch),
        (0.04,) * 3,
        -1,
    )
    red_lit = bool(rng.random() < c.signal_red_share)
    out: list[Emitter] = []
    for k in range(n):
        centre = (x, top + k * pitch + pitch // 2)
        if k == 0:
            colour = _red(rng, c, 1.0 if red_lit else float(rng.uniform(*c.dark_val)))
            lit = red_lit
        else:
            lit = not red_lit and k == 1
            colour = (0.2, 1.0, 0.5) if rng.random() < 0.5 else (1.0, 0.75, 0.1)
            colour = colour if lit else (0.05, 0.07, 0.06)
        e = _lens(rng, img, centre, r, False, lit, colour, c)
        if e is not None:
            out.append(e)
    return out


def _road_lights(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, c: LampRanges
) -> list[Emitter]:
    h, w = img.shape[:2]
    vw = int(w * rng.uniform(*c.road_width))
    x0 = int(rng.uniform(0, max(1, w - vw)))
    y0 = int(h * rng.uniform(0.55, 0.85))
    vh = int(vw * rng.uniform(0.5, 0.8))
    body = tuple(float(v) for v in rng.uniform(0.05, 0.7, 3))
    cv2.rectangle(img, (x0, y0), (x0 + vw, y0 + vh), body, -1)
    lw, lh = max(1, int(vw * rng.uniform(0.06, 0.12))), max(1, int(vh * rng.uniform(0.06, 0.14)))
    lit = bool(rng.random() < c.lit_share)
    colour = _red(rng, c, 1.0 if lit else float(rng.uniform(*c.dark_val)))
    out = []
    for cx in (x0 + int(vw * 0.15), x0 + int(vw * 0.85)):
        cy = y0 + int(vh * rng.uniform(0.2, 0.45))
        cv2.rectangle(img, (cx - lw, cy - lh), (cx + lw, cy + lh), colour, -1)
        if lit:
            out.append(
                Emitter(
                    (cx, cy),
                    (lw, lh),
                    True,
                    colour,
                    float(rng.uniform(*c.gain)),
                    float(max(lw, lh) * rng.uniform(*c.bloom)),
                    float(rng.uniform(*c.halo)),
                )
            )
    return out


def draw_lamp(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, kind: str, c: LampRanges = LAMPS
) -> list[Emitter]:
    """Paint one lamp kind (see :data:`LAMP_KINDS`) into the unlit scene; its lit lenses.

    Raises
    ------
    ValueError
        Unknown kind.
    """
    if kind == "tail_lamp":
        return _tail_lamps(rng, img, geo, c)
    if kind == "signal_head":
        return _signal(rng, img, geo, c)
    if kind == "road_tail_lights":
        return _road_lights(rng, img, geo, c)
    raise ValueError(f"unknown lamp {kind!r}; use one of {LAMP_KINDS}")


def emit(img: FloatImage, emitters: list[Emitter]) -> FloatImage:
    """Add the light of lit lenses to the lit scene: the lens at its gain, a halo."""
    h, w = img.shape[:2]
    out = img
    for e in emitters:
        g = np.zeros((h, w), np.float32)
        (x, y), (sx, sy) = e.centre, e.size
        if e.square:
            cv2.rectangle(g, (x - sx, y - sy), (x + sx, y + sy), 1.0, -1)
        else:
            cv2.ellipse(g, (x, y), (sx, sy), 0, 0, 360, 1.0, -1, cv2.LINE_AA)
        halo = cv2.GaussianBlur(g, (0, 0), max(0.8, e.bloom))
        light = g + e.halo * np.asarray(halo, np.float32) / max(float(halo.max()), 1e-6)
        glow = (light * np.float32(e.gain))[..., None] * np.asarray(e.colour, np.float32)
        out = np.asarray(out + glow, np.float32)
    return out
