"""Drawing for the domain-randomised generator A (:mod:`tail_check.synth_wide`).

Every range lives in :class:`WideRanges`. The ranges follow the kinds of scene the
issue lists as failures, by principle rather than by imitating another generator:
paint of any red from signal red to faded pink and red-brown, discs turned about the
vertical (an ellipse down to a sliver), discs far from the camera, lettering with
closed bowls in the same paints, snow on the disc, and a lit reflector at night whose
return ranges from deep red to an almost white glare.
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from ._scene import CarGeometry, FloatImage

__all__ = [
    "WIDE",
    "WideRanges",
    "car_paint",
    "draw_lettering",
    "draw_roundel",
    "red_paint",
    "snow_clump",
]

Range = tuple[float, float]
Paint = tuple[float, float, float]


@dataclass(frozen=True)
class WideRanges:
    """Ranges of the domain randomisation (colours as HSV: hue in degrees, 0..1 else).

    Attributes
    ----------
    car_width : car width as a fraction of the image width (near to far cameras).
    red_car_share : share of cars painted in the red family (``red_hue`` ... with body
        saturation and value); the rest get any hue, mostly unsaturated.
    red_hue, red_sat, red_val : the red family: crimson through signal red to rust.
    body_sat, body_val : saturation and value of the bodies of the red family.
    other_sat, other_val : of the other bodies.
    disc_hue, disc_sat, disc_val : the disc's (and red lettering's) paint, faded pink
        (low saturation) to fresh signal red.
    disc_radius : disc radius as a fraction of the car width.
    turn_share, turn_deg : share of discs turned about the vertical axis by up to
        ``turn_deg`` (the rest up to ``small_turn_deg``); width shrinks with cos(turn).
    tilt_deg : roll of the disc's ellipse.
    reflector : reflector radius as a fraction of the disc radius.
    pale_reflector_share : share of reflectors that return daylight pale pink / white.
    rim_share : share of discs with a dark rim; ``rim`` its width in disc radii.
    protrude_share : share of discs mounted beyond the body's outline (sky, ground,
        the next car behind it).
    lift : the disc centre sits this many radii above the beam's top edge.
    pole_share, pole_cover : a pole in front of the disc and the share it hides.
    lamp_share : share of scenes with a lamp (tail lamp, signal, road vehicle's lights,
        :mod:`tail_check._wide_lamps`) besides the drawn hard negatives.
    clump_share, clump_cover : snow stuck on the disc (snow scenes) and its size.
    dusk_gain : extra exposure factor at dusk (small discs nearly black).
    white_balance : per-channel gain range of the camera's white balance.
    exposure : overall exposure error.
    glow_gain, glow_white : lit reflector at night: strength and how far its colour
        goes from red towards white.
    letter_height : red lettering height, fraction of the image height ...
    letter_body : ... and at most this fraction of the body height.
    roundel_radius : a round red logo (a roundel with white letters) has this many
        disc radii (:attr:`disc_radius`): the closed red bowl of a disc's own size ...
    roundel_letters : ... and letters this fraction of its diameter high.
    roundel_share : share of scenes with such a roundel. 0 by default: with one in 14
        of the training scenes the retrained verifiers doubted plain discs (a clean
        disc of radius 2 % of 1080 px held ``uncertain``; ``AB`` reached its ``present``
        threshold on none of its validation discs), because the features see a disc
        at the working scale, where white letters blur into a reflector.
    jpeg : JPEG quality range (inclusive).
    """

    car_width: Range = (0.28, 0.9)
    red_car_share: float = 0.4
    red_hue: Range = (-14.0, 26.0)
    red_sat: Range = (0.3, 0.95)
    red_val: Range = (0.4, 1.0)
    body_sat: Range = (0.35, 0.9)
    body_val: Range = (0.18, 0.8)
    other_sat: Range = (0.0, 0.6)
    other_val: Range = (0.1, 0.85)
    disc_hue: Range = (-12.0, 12.0)
    disc_sat: Range = (0.42, 0.95)
    disc_val: Range = (0.45, 1.0)
    disc_radius: Range = (0.032, 0.07)
    turn_share: float = 0.35
    turn_deg: float = 72.0
    small_turn_deg: float = 25.0
    tilt_deg: float = 15.0
    reflector: Range = (0.12, 0.45)
    pale_reflector_share: float = 0.45
    rim_share: float = 0.6
    rim: Range = (0.04, 0.12)
    protrude_share: float = 0.3
    lift: Range = (-0.2, 1.6)
    pole_share: float = 0.12
    lamp_share: float = 0.3
    pole_cover: Range = (0.1, 0.5)
    clump_share: float = 0.35
    clump_cover: Range = (0.15, 0.45)
    dusk_gain: Range = (0.3, 1.0)
    white_balance: Range = (0.9, 1.12)
    exposure: Range = (0.75, 1.25)
    glow_gain: Range = (0.8, 2.5)
    glow_white: Range = (0.1, 0.85)
    letter_height: Range = (0.05, 0.11)
    letter_body: float = 0.35
    roundel_radius: Range = (0.8, 1.8)
    roundel_letters: Range = (0.3, 0.6)
    roundel_share: float = 0.0
    jpeg: tuple[int, int] = (50, 95)


WIDE = WideRanges()
LETTERS = "DPOBR8096QA"
"""Letters and digits with closed bowls (the issue's false `present`: D, P, O, Р)."""
_WHITE: Paint = (0.9, 0.9, 0.88)
FONTS = (cv2.FONT_HERSHEY_SIMPLEX, cv2.FONT_HERSHEY_DUPLEX, cv2.FONT_HERSHEY_TRIPLEX)


def _hsv(hue_deg: float, sat: float, val: float) -> Paint:
    r, g, b = colorsys.hsv_to_rgb((hue_deg % 360.0) / 360.0, sat, val)
    return (float(r), float(g), float(b))


def red_paint(rng: np.random.Generator, c: WideRanges = WIDE) -> Paint:
    """Any red paint a disc, a letter or a plate may have (faded pink to signal red)."""
    return _hsv(rng.uniform(*c.disc_hue), rng.uniform(*c.disc_sat), rng.uniform(*c.disc_val))


def car_paint(rng: np.random.Generator, c: WideRanges = WIDE) -> tuple[str, Paint]:
    """A body paint and its family name (``red`` family or ``other``)."""
    if rng.random() < c.red_car_share:
        paint = _hsv(rng.uniform(*c.red_hue), rng.uniform(*c.body_sat), rng.uniform(*c.body_val))
        return "red", paint
    paint = _hsv(rng.uniform(0, 360), rng.uniform(*c.other_sat), rng.uniform(*c.other_val))
    return "other", paint


@dataclass(frozen=True)
class DiscDrawn:
    """The drawn disc: its mask, centre, radius, reflector radius and paint."""

    mask: NDArray[np.bool_]
    centre: tuple[int, int]
    radius: float
    reflector: int
    paint: Paint


def _place(
    rng: np.random.Generator, geo: CarGeometry, r: float, width: int, c: WideRanges
) -> tuple[int, int]:
    """The disc centre: on its bracket at the beam, right side, or beyond the body
    (only where the whole disc stays in the frame)."""
    cw = geo.width
    if rng.random() < c.protrude_share and geo.right + 2.5 * r < width:
        cx = geo.right + r * rng.uniform(-0.2, 1.3)
    else:
        cx = geo.right - cw * rng.uniform(0.1, 0.28)
    cy = geo.beam_top - r * rng.uniform(*c.lift)
    return int(cx), int(cy)


def draw_disc_wide(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, c: WideRanges = WIDE
) -> DiscDrawn:
    """Draw a tail disc with randomised paint, turn, rim, reflector and mounting."""
    h, w = img.shape[:2]
    r = max(2.5, geo.width * rng.uniform(*c.disc_radius))
    cx, cy = _place(rng, geo, r, w, c)
    limit = c.turn_deg if rng.random() < c.turn_share else c.small_turn_deg
    squash = max(0.2, math.cos(math.radians(rng.uniform(0.0, limit))))
    axes = (max(1, int(round(r * squash))), max(2, int(round(r))))
    tilt = rng.uniform(-c.tilt_deg, c.tilt_deg)
    stalk = max(1, int(r * rng.uniform(0.12, 0.3)))
    dark = float(rng.uniform(0.04, 0.2))
    cv2.rectangle(img, (cx - stalk // 2, cy), (cx + stalk // 2, geo.beam_bottom), (dark,) * 3, -1)
    if rng.random() < c.rim_share:
        rim = max(1, int(round(r * rng.uniform(*c.rim))))
        grown = (axes[0] + rim, axes[1] + rim)
        cv2.ellipse(img, (cx, cy), grown, tilt, 0, 360, (dark,) * 3, -1, cv2.LINE_AA)
    mask_u8 = np.zeros((h, w), np.uint8)
    cv2.ellipse(mask_u8, (cx, cy), axes, tilt, 0, 360, 1, -1, cv2.LINE_AA)
    mask = mask_u8 > 0
    paint = red_paint(rng, c)
    ys, xs = np.nonzero(mask)
    gx, gy = rng.uniform(-0.25, 0.25, 2)
    shade = 1 + gx * (xs - cx) / r + gy * (ys - cy) / r
    shade *= 1 - rng.uniform(0.0, 0.3) * rng.random(xs.size) ** 4  # flaked paint
    img[ys, xs] = np.asarray(paint, np.float32)[None, :] * shade[:, None].astype(np.float32)
    rr = rng.uniform(*c.reflector)
    refl = (max(1, int(axes[0] * rr)), max(1, int(axes[1] * rr)))
    if rng.random() < c.pale_reflector_share:
        mix = rng.uniform(0.3, 0.85)
        centre = tuple(float(p * (1 - mix) + mix) for p in paint)
    else:
        k = rng.uniform(0.7, 1.35)
        centre = tuple(float(min(1.0, p * k)) for p in paint)
    cv2.ellipse(img, (cx, cy), refl, tilt, 0, 360, centre, -1, cv2.LINE_AA)
    return DiscDrawn(mask, (cx, cy), r, max(refl), paint)


def add_glow(
    rng: np.random.Generator, img: FloatImage, disc: DiscDrawn, c: WideRanges = WIDE
) -> FloatImage:
    """The reflector returning the camera's light at night (red to almost white)."""
    h, w = img.shape[:2]
    g = np.zeros((h, w), np.float32)
    cv2.circle(g, disc.centre, max(1, disc.reflector), 1.0, -1, cv2.LINE_AA)
    blur = max(0.8, disc.reflector * rng.uniform(0.4, 1.2))
    g = np.asarray(cv2.GaussianBlur(g, (0, 0), blur), np.float32)
    white = rng.uniform(*c.glow_white)
    colour = np.asarray([1.0, white * 0.9, white], np.float32) * rng.uniform(*c.glow_gain)
    return np.asarray(img + g[..., None] * colour, np.float32)


def snow_clump(
    rng: np.random.Generator, img: FloatImage, disc: DiscDrawn, c: WideRanges = WIDE
) -> NDArray[np.bool_]:
    """A clump of snow stuck on the disc's edge; returns its mask."""
    h, w = img.shape[:2]
    mask = np.zeros((h, w), np.uint8)
    a = rng.uniform(0, 2 * math.pi)
    size = disc.radius * math.sqrt(rng.uniform(*c.clump_cover)) * 1.6
    for _ in range(int(rng.integers(3, 7))):
        d = disc.radius * rng.uniform(0.6, 1.1)
        px = disc.centre[0] + d * math.cos(a) + rng.normal(0, size * 0.3)
        py = disc.centre[1] + d * math.sin(a) + rng.normal(0, size * 0.3)
        cv2.circle(mask, (int(px), int(py)), max(1, int(size * rng.uniform(0.4, 0.8))), 1, -1)
    snow = np.float32(rng.uniform(0.8, 0.97))
    img[mask > 0] = snow
    return mask > 0


def _paint_text(
    img: FloatImage,
    text: str,
    origin: tuple[int, int],
    font: int,
    scale: float,
    thick: int,
    paint: Paint,
    line_type: int = cv2.LINE_8,
) -> None:
    """Blend ``text`` in ``paint`` into the float image (in place)."""
    ink = np.zeros(img.shape[:2], np.uint8)  # OpenCV writes text on 8-bit images only
    cv2.putText(ink, text, origin, font, scale, 255, thick, line_type)
    alpha = (ink.astype(np.float32) / 255.0)[..., None]
    img[:] = img * (1 - alpha) + alpha * np.asarray(paint, np.float32)


def draw_lettering(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, c: WideRanges = WIDE
) -> None:
    """Red letters with closed bowls mid-body, in any red a disc could have."""
    h = img.shape[0]
    body = geo.beam_top - geo.top
    height = min(h * rng.uniform(*c.letter_height), body * c.letter_body)
    font = FONTS[int(rng.integers(len(FONTS)))]
    scale = cv2.getFontScaleFromHeight(font, max(4, int(height)), 1)
    thick = max(1, int(height * rng.uniform(0.1, 0.25)))
    text = "".join(rng.choice(list(LETTERS), int(rng.integers(1, 5))))
    (tw, _), _ = cv2.getTextSize(text, font, scale, thick)
    x = geo.left + int(max(1, geo.width - tw) * rng.uniform(0.0, 1.0))
    y = geo.top + int(body * rng.uniform(0.2, 0.75) + height / 2)
    _paint_text(img, text, (x, y), font, scale, thick, red_paint(rng, c), cv2.LINE_AA)


def draw_roundel(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, c: WideRanges = WIDE
) -> None:
    """A round red logo with white letters on the body, in any red a disc could have.

    A red disc of a tail disc's size, its centre broken only by thin white strokes: the
    kind of logo a verifier that learnt only plates and lettering calls a disc. It sits
    anywhere on the end wall above the disc's own zone (logos are painted mid-body).
    """
    body = geo.beam_top - geo.top
    r = max(3.0, geo.width * rng.uniform(*c.disc_radius) * rng.uniform(*c.roundel_radius))
    r = min(r, body * 0.4)
    cx = geo.left + r + max(1.0, geo.width - 2 * r) * rng.uniform(0.0, 1.0)
    cy = geo.top + r + max(1.0, body * 0.8 - 2 * r) * rng.uniform(0.0, 1.0)
    centre = (int(cx), int(cy))
    cv2.circle(img, centre, int(r), red_paint(rng, c), -1, cv2.LINE_AA)
    if rng.random() < 0.5:  # a white ring round the lettering, as many roundels have
        cv2.circle(img, centre, int(r * 0.8), _WHITE, max(1, int(r * 0.06)), cv2.LINE_AA)
    font = FONTS[int(rng.integers(len(FONTS)))]
    height = max(3, int(2 * r * rng.uniform(*c.roundel_letters)))
    scale = cv2.getFontScaleFromHeight(font, height, 1)
    thick = max(1, int(height * rng.uniform(0.1, 0.2)))
    text = "".join(rng.choice(list(LETTERS), int(rng.integers(1, 4))))
    (tw, th), _ = cv2.getTextSize(text, font, scale, thick)
    scale *= min(1.0, 1.4 * r / max(1, tw))  # the letters stay inside the roundel
    (tw, th), _ = cv2.getTextSize(text, font, scale, thick)
    _paint_text(img, text, (int(cx - tw / 2), int(cy + th / 2)), font, scale, thick, _WHITE)


def draw_barrier(
    rng: np.random.Generator, img: FloatImage, geo: CarGeometry, c: WideRanges = WIDE
) -> None:
    """A red and white striped barrier arm across the scene, in front of the car."""
    h, w = img.shape[:2]
    y = int(geo.beam_bottom + (h - geo.beam_bottom) * rng.uniform(0.0, 0.6))
    th = max(2, int(geo.width * rng.uniform(0.02, 0.05)))
    seg = max(4, int(geo.width * rng.uniform(0.06, 0.14)))
    red = red_paint(rng, c)
    for k, x in enumerate(range(0, w, seg)):
        colour = red if k % 2 == 0 else _WHITE
        cv2.rectangle(img, (x, y), (x + seg, y + th), colour, -1)
