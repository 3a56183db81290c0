"""Scene layout: what is in the scene and where the camera stands.

All random choices about *content* are drawn here, one after the other from the
scene's generator, so that the painting code in :mod:`._render` only executes
a :class:`Layout`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._camera import Camera
from ._car import BEAM_TOP, CarSpec, choose_car
from ._config import CONDITIONS, NEGATIVE_KINDS, RANGES, Rng, uniform
from ._scenery import BACKGROUNDS

PAINTED_KINDS = ("red_lettering", "red_stripe", "red_logo", "hand_wheel")
EXTRA_KINDS = (*PAINTED_KINDS, "signal_light", "tail_lamp")
"""Hard negatives that may also appear beside a real disc (no barrier in front of it)."""


@dataclass(frozen=True)
class Layout:
    """Content and geometry of one scene (metres, pixels, radians)."""

    width: int
    height: int
    condition: str
    disc: bool
    negative_kind: str | None
    extras: tuple[str, ...]
    car: CarSpec
    camera: Camera
    end_z: float
    disc_pos: tuple[float, float, float]
    disc_radius: float
    disc_turn: tuple[float, float]
    background: str
    pole_occlusion: bool
    stripe_beside_disc: bool


def choose_size(rng: Rng) -> tuple[int, int]:
    """Width and height, 4:3 from 800×600 to 1440×1080 or 16:9 from 1068×600 to 1920×1080."""
    if rng.random() < 0.5:
        width = int(rng.integers(400, 721)) * 2
        return width, int(round(width * 3 / 4 / 2)) * 2
    width = int(rng.integers(534, 961)) * 2
    return width, min(1080, max(600, int(round(width * 9 / 16 / 2)) * 2))


def _disc_fraction(rng: Rng, condition: str, kind: str | None) -> float:
    """Disc radius as a fraction of image height (nominal even without a disc)."""
    if kind == "red_car_body":
        return uniform(rng, (0.04, RANGES.disc_radius_frac[1]))
    if condition == "dusk" and rng.random() < 0.6:
        return uniform(rng, (RANGES.disc_radius_frac[0], 0.03))
    low, high = RANGES.disc_radius_frac
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))  # log-uniform: many small


def _camera(rng: Rng, size: tuple[int, int], disc_pos: tuple[float, float, float],
            r_frac: float, r_m: float) -> tuple[Camera, float]:
    """Camera beside the track aimed near the disc; returns it and the end wall Z."""
    width, height = size
    focal = width / 2.0 / np.tan(np.deg2rad(uniform(rng, RANGES.fov_deg)) / 2.0)
    dist = max(RANGES.min_distance_m, focal * r_m / (r_frac * height))
    cam_x = (1.0 if rng.random() < 0.5 else -1.0) * uniform(rng, RANGES.cam_lateral_m)
    cam_y = uniform(rng, RANGES.cam_height_m)
    dx, dy = disc_pos[0] - cam_x, disc_pos[1] - cam_y
    dz = max(0.75 * dist, float(np.sqrt(max(0.0, dist**2 - dx**2 - dy**2))))
    dist = float(np.sqrt(dx**2 + dy**2 + dz**2))
    focal = r_frac * height * dist / r_m  # keep the drawn disc radius
    half_w, half_h = dist * width / (2 * focal), dist * height / (2 * focal)
    target = (disc_pos[0] + rng.uniform(-0.55, 0.55) * half_w,
              disc_pos[1] + rng.uniform(-0.45, 0.45) * half_h, dz)
    end_z = dz + 0.12  # the disc hangs just in front of the end wall
    cam = Camera.looking_at(width, height, focal, (cam_x, cam_y, 0.0),
                            (target[0], target[1], end_z))
    return cam, end_z


def _car_for(rng: Rng, condition: str, kind: str | None, extras: tuple[str, ...]) -> CarSpec:
    """Car whose paint suits the scene: red for red_car_body, often dark red at dusk,
    mostly not red when a red marking must stand out."""
    if kind == "red_car_body" or (condition == "dusk" and rng.random() < 0.5):
        return choose_car(rng, red_body=True)
    car = choose_car(rng, red_body=False)
    painted = kind in PAINTED_KINDS or any(e in PAINTED_KINDS for e in extras)
    for _ in range(3):
        if not (painted and car.paint in ("bright_red", "dark_red") and rng.random() < 0.7):
            break
        car = choose_car(rng, red_body=False)
    return car


def choose_layout(rng: Rng, disc: bool | None, condition: str | None,
                  size: tuple[int, int] | None) -> Layout:
    """Draw every content choice of a scene (overrides replace, never skip, a draw)."""
    drawn_disc = bool(rng.random() < RANGES.p_disc)
    drawn_condition = CONDITIONS[int(rng.integers(len(CONDITIONS)))]
    drawn_size = choose_size(rng)
    has_disc = drawn_disc if disc is None else disc
    cond = drawn_condition if condition is None else condition
    width, height = drawn_size if size is None else size
    drawn_kind = NEGATIVE_KINDS[int(rng.integers(len(NEGATIVE_KINDS)))]
    kind = None if has_disc else drawn_kind
    extras: tuple[str, ...] = ()
    if has_disc and rng.random() < RANGES.p_extra_distractor:
        extras = (EXTRA_KINDS[int(rng.integers(len(EXTRA_KINDS)))],)
    car = _car_for(rng, cond, kind, extras)
    r_m = uniform(rng, RANGES.disc_radius_m)
    side = 1.0 if rng.random() < RANGES.p_disc_right else -1.0
    disc_x = side * (car.width / 2.0 - r_m - uniform(rng, (0.02, 0.25)))
    disc_y = BEAM_TOP + r_m + uniform(rng, (0.03, 0.4))
    disc_pos = (disc_x, disc_y, 0.0)
    r_frac = _disc_fraction(rng, cond, kind)
    camera, end_z = _camera(rng, (width, height), disc_pos, r_frac, r_m)
    return Layout(
        width=width, height=height, condition=cond, disc=has_disc, negative_kind=kind,
        extras=extras, car=car, camera=camera, end_z=end_z,
        disc_pos=(disc_x, disc_y, end_z - 0.12), disc_radius=r_m,
        disc_turn=(np.deg2rad(uniform(rng, RANGES.disc_yaw_deg)),
                   np.deg2rad(uniform(rng, RANGES.disc_pitch_deg))),
        background=BACKGROUNDS[int(rng.integers(len(BACKGROUNDS)))],
        pole_occlusion=bool(rng.random() < RANGES.p_pole_occlusion),
        stripe_beside_disc=bool(rng.random() < 0.2),
    )
