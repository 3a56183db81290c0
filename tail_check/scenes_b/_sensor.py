"""What the camera does to the light: mild rotation/shear/zoom, blur, vignetting,
exposure error, sensor noise, tone curve and the JPEG round trip."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from ._config import RANGES, FloatImage, FloatMap, Rng, f32, uniform

Uint8Image = npt.NDArray[np.uint8]


def tilt(image: FloatImage, disc_mask: FloatMap | None, rng: Rng
         ) -> tuple[FloatImage, FloatMap | None]:
    """Mild rotation, shear and zoom about the image centre (mast not quite level)."""
    h, w = image.shape[:2]
    angle = np.deg2rad(uniform(rng, RANGES.rotation_deg))
    shear = uniform(rng, RANGES.shear)
    zoom = uniform(rng, RANGES.zoom)
    cos, sin = np.cos(angle) * zoom, np.sin(angle) * zoom
    lin = np.array([[cos, -sin], [sin, cos]]) @ np.array([[1.0, shear], [0.0, 1.0]])
    centre = np.array([w / 2.0, h / 2.0])
    matrix = np.hstack([lin, (centre - lin @ centre)[:, None]])
    out = cv2.warpAffine(image, matrix, (w, h), flags=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REFLECT)
    mask: FloatMap | None = None
    if disc_mask is not None:
        mask = f32(cv2.warpAffine(disc_mask, matrix, (w, h), flags=cv2.INTER_LINEAR))
    return f32(out), None if mask is None else f32(mask)


def optics(image: FloatImage, rng: Rng, *, night: bool) -> FloatImage:
    """Motion blur (train or camera shake), slight defocus, vignetting."""
    h, w = image.shape[:2]
    out = image
    if rng.random() < RANGES.p_motion_blur:
        length = max(3, int(h * uniform(rng, (0.003, 0.014))))
        kernel = np.zeros((length, length), np.float32)
        kernel[length // 2, :] = 1.0 / length
        rot = cv2.getRotationMatrix2D((length / 2 - 0.5, length / 2 - 0.5),
                                      uniform(rng, (-20.0, 20.0)), 1.0)
        kernel = f32(cv2.warpAffine(kernel, rot, (length, length)))
        kernel /= max(float(kernel.sum()), 1e-6)
        out = f32(cv2.filter2D(out, -1, kernel))
    sigma = uniform(rng, (0.0, 1.3)) * h / 1080.0
    if sigma > 0.3:
        out = f32(cv2.GaussianBlur(out, (0, 0), sigma))
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    r2 = ((xs - w / 2) / (w / 2)) ** 2 + ((ys - h / 2) / (h / 2)) ** 2
    strength = uniform(rng, (0.0, 0.45 if night else 0.3))
    out = f32(out * (1.0 - strength * r2 / 2.0)[..., None])
    return f32(out)


def sensor(image: FloatImage, rng: Rng, *, night: bool) -> Uint8Image:
    """Exposure error, white balance, shot and read noise, tone curve → uint8."""
    bad = rng.random() < RANGES.p_bad_exposure
    gain = uniform(rng, RANGES.bad_exposure_gain if bad else RANGES.exposure_gain)
    gain *= uniform(rng, (1.5, 3.0)) if night else 1.0
    balance = np.asarray([uniform(rng, (0.92, 1.08)) for _ in range(3)], np.float32)
    linear = np.clip(image * gain * balance / 255.0, 0.0, None)
    sigma = uniform(rng, RANGES.noise_sigma) * (2.5 if night else 1.0) / 255.0
    noise = rng.standard_normal(linear.shape).astype(np.float32)
    shot = np.sqrt(linear * 0.004 + sigma**2)
    linear = np.clip(linear + noise * shot, 0.0, None)
    knee = uniform(rng, (0.85, 1.0))  # soft shoulder: highlights roll off instead of clipping
    toned = np.where(linear < knee, linear, knee + (1 - knee) * np.tanh((linear - knee) /
                                                                         max(1e-3, 1 - knee)))
    gamma = uniform(rng, (0.9, 1.1))
    out = np.clip(np.power(np.clip(toned, 0.0, 1.0), gamma) * 255.0, 0, 255)
    return np.asarray(np.round(out), dtype=np.uint8)


def jpeg_round_trip(image: Uint8Image, rng: Rng) -> Uint8Image:
    """Encode and decode at a random quality in RANGES.jpeg_quality (inclusive)."""
    low, high = RANGES.jpeg_quality
    quality = int(rng.integers(low, high + 1))
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise RuntimeError("JPEG encoding failed")
    decoded = cv2.imdecode(data, cv2.IMREAD_COLOR)
    return np.asarray(decoded, dtype=np.uint8)
