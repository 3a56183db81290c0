"""Tunable ranges of the independent trackside-scene generator (generator B).

Every random range the renderer draws from lives in :class:`SceneRanges`, so a
reader can see the whole scene distribution in one place. Lengths are metres in
the world frame (X to the right as seen from the camera, Y up from rail top, Z
along the track away from the camera), angles degrees, fractions of the image
height where stated.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

FloatImage = npt.NDArray[np.float32]
"""H×W×3 float32 BGR in 0..255 (may exceed 255 before tone mapping)."""
FloatMap = npt.NDArray[np.float32]
"""H×W float32 (depth in metres, masks in 0..1)."""
Rng = np.random.Generator
BGR = tuple[float, float, float]

CONDITIONS: tuple[str, ...] = (
    "daylight",
    "overcast",
    "dusk",
    "night",
    "rain",
    "snow",
    "fog",
)

NEGATIVE_KINDS: tuple[str, ...] = (
    "red_lettering",
    "red_stripe",
    "red_logo",
    "red_car_body",
    "signal_light",
    "tail_lamp",
    "hand_wheel",
    "red_barrier",
    "none",
)

CAR_SHAPES: tuple[str, ...] = ("box", "gondola", "tank", "hopper", "flat")

CAR_PAINTS: tuple[str, ...] = (
    "red_brown",
    "dark_red",
    "bright_red",
    "rusty",
    "green",
    "blue",
    "grey",
    "black_tank",
    "silver",
)


@dataclass(frozen=True)
class SceneRanges:
    """Ranges of every randomised scene quantity.

    Attributes
    ----------
    disc_radius_frac : disc radius in the image, fraction of image height.
    disc_radius_m : physical disc radius, metres.
    fov_deg : horizontal field of view of the camera, degrees.
    cam_lateral_m : camera offset from the track centre line, metres.
    cam_height_m : camera height above rail top, metres (below car roofs so
        roofs and gondola insides never need drawing).
    min_distance_m : nearest allowed camera-to-end-wall distance, metres.
    aim_jitter : aim point jitter, fraction of the distance (moves the disc
        around the frame).
    car_length_m : car body length, metres.
    jpeg_quality : JPEG quality of the final round trip (inclusive).
    rotation_deg, shear, zoom : final mild image warp (rotation, x-shear,
        zoom-in factor that hides the warp's borders).
    disc_yaw_deg, disc_pitch_deg : turn of the disc on its bracket relative to
        the end wall (the end wall itself is seen at up to ~41° off-axis).
    pole_width, pole_offset : occluding pole width and its centre's offset
        from the disc centre, in disc radii (so part of the disc stays visible).
    p_disc : probability of a disc when ``disc=None``.
    p_disc_right : probability the disc hangs on the right (instruction side).
    p_pole_occlusion : probability a near pole cuts across the disc.
    p_snow_clump : probability of snow clumps on the disc in snow scenes.
    p_white_rim, p_dark_rim : probabilities of a white / dark disc rim.
    p_extra_distractor : probability a disc scene also gets a hard negative.
    p_motion_blur : probability of horizontal motion blur.
    noise_sigma : sensor noise standard deviation, 0..255 units.
    exposure_gain : global exposure error factor.
    p_bad_exposure, bad_exposure_gain : probability and range of a gross
        exposure error (auto-exposure fooled by sky, snow or headlights).
    p_rust : probability of rust patches on a car not painted "rusty"
        (rusty cars always get them).
    """

    disc_radius_frac: tuple[float, float] = (0.015, 0.08)
    disc_radius_m: tuple[float, float] = (0.12, 0.16)
    fov_deg: tuple[float, float] = (26.0, 62.0)
    cam_lateral_m: tuple[float, float] = (2.3, 6.0)
    cam_height_m: tuple[float, float] = (1.0, 3.2)
    min_distance_m: float = 4.0
    aim_jitter: float = 0.12
    car_length_m: tuple[float, float] = (12.0, 19.0)
    jpeg_quality: tuple[int, int] = (50, 95)
    rotation_deg: tuple[float, float] = (-3.0, 3.0)
    shear: tuple[float, float] = (-0.04, 0.04)
    zoom: tuple[float, float] = (1.03, 1.10)
    disc_yaw_deg: tuple[float, float] = (-15.0, 15.0)
    disc_pitch_deg: tuple[float, float] = (-8.0, 8.0)
    pole_width: tuple[float, float] = (0.3, 0.8)
    pole_offset: tuple[float, float] = (0.2, 1.0)
    p_disc: float = 0.5
    p_disc_right: float = 0.85
    p_pole_occlusion: float = 0.15
    p_snow_clump: float = 0.5
    p_white_rim: float = 0.2
    p_dark_rim: float = 0.7
    p_extra_distractor: float = 0.35
    p_motion_blur: float = 0.25
    noise_sigma: tuple[float, float] = (1.0, 6.0)
    exposure_gain: tuple[float, float] = (0.7, 1.35)
    p_bad_exposure: float = 0.12
    bad_exposure_gain: tuple[float, float] = (0.4, 2.0)
    p_rust: float = 0.15


RANGES = SceneRanges()


def f32(values: object) -> npt.NDArray[np.float32]:
    """``values`` as a float32 array (typed, for OpenCV and numpy results)."""
    return np.asarray(values, dtype=np.float32)


def uniform(rng: Rng, bounds: tuple[float, float]) -> float:
    """One draw from ``[low, high)`` as a Python float (``low`` if the range is empty)."""
    low, high = bounds
    return float(rng.uniform(low, max(low, high)))


def hsv_to_bgr(hue: float, sat: float, val: float) -> BGR:
    """OpenCV-scaled HSV (hue 0..180, sat/val 0..255) to a BGR float triple."""
    pixel = np.array([[[hue % 180.0, sat, val]]], dtype=np.float32)
    pixel[..., 1:] = np.clip(pixel[..., 1:], 0.0, 255.0)
    hsv8 = np.round(pixel).astype(np.uint8)
    bgr = cv2.cvtColor(hsv8, cv2.COLOR_HSV2BGR)
    return (float(bgr[0, 0, 0]), float(bgr[0, 0, 1]), float(bgr[0, 0, 2]))
