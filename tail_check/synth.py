"""Realistic labelled last-car snapshots for tests, benchmarks and the ε(c_Δ) study.

A scene (car rear, buffer beam, buffers, optional tail disc, red objects that are
not discs) is lit for a condition (day, dusk, night with a lit reflector, fog,
snow, rain), then passed through a camera model: colour cast, partial occlusion,
motion blur, defocus, noise and JPEG compression. The label records the truth:
whether a disc is on the car, its box and its visible pixel fraction ``s_ref``.
"""

from __future__ import annotations

import csv
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from ._distractors import DISTRACTORS, draw_distractor
from ._scene import CAR_COLOURS, FloatImage, background, draw_car, draw_disc

__all__ = [
    "CAR_COLOURS",
    "CONDITIONS",
    "DISTRACTORS",
    "LABEL_FIELDS",
    "SnapshotLabel",
    "random_snapshot",
    "render_snapshot",
    "write_study_set",
]

CONDITIONS = ("day", "dusk", "night", "fog", "snow", "rain")
_CONDITION_WEIGHTS = (0.30, 0.15, 0.15, 0.13, 0.13, 0.14)
_SKY = {
    "day": (0.62, 0.74, 0.90),
    "dusk": (0.75, 0.52, 0.40),
    "night": (0.05, 0.05, 0.08),
    "fog": (0.72, 0.74, 0.76),
    "snow": (0.80, 0.82, 0.85),
    "rain": (0.50, 0.53, 0.57),
}
# Share of each car colour in a mixed freight fleet (order of CAR_COLOURS).
_FLEET_SHARES = (0.18, 0.12, 0.08, 0.10, 0.05, 0.15, 0.08, 0.12, 0.04, 0.08)
LABEL_FIELDS = (
    "file",
    "disc",
    "x",
    "y",
    "w",
    "h",
    "s_ref",
    "ref_x",
    "ref_y",
    "condition",
    "car_colour",
    "distractors",
    "occluded",
)


@dataclass(frozen=True)
class SnapshotLabel:
    """Ground truth of one generated snapshot.

    Attributes
    ----------
    disc : bool
        A tail disc is on the car (even if partly hidden).
    bbox : (x, y, w, h) or None
        Box of the visible disc pixels.
    disc_fraction : float
        ``s_ref``: visible disc pixels / image pixels.
    reference_point : (x, y) or None
        A pixel inside the disc, away from the reflector (for picking ``c_ref``).
    condition : str
    car_colour : str
    distractors : tuple of str
    occluded : float
        Share of the disc hidden by an occluder.
    weak_disc : bool
    """

    disc: bool
    bbox: tuple[int, int, int, int] | None
    disc_fraction: float
    reference_point: tuple[int, int] | None
    condition: str
    car_colour: str
    distractors: tuple[str, ...]
    occluded: float
    weak_disc: bool


def _as_rng(seed_or_rng: int | np.random.Generator) -> np.random.Generator:
    if isinstance(seed_or_rng, np.random.Generator):
        return seed_or_rng
    return np.random.default_rng(int(seed_or_rng))


def _light_raw(
    rng: np.random.Generator, img: FloatImage, condition: str, glow: list[tuple[int, int, int]]
) -> NDArray[np.floating[Any]]:
    h, w = img.shape[:2]
    xs = np.linspace(-1, 1, w, dtype=np.float32)[None, :]
    if condition == "day":
        return img * rng.uniform(0.85, 1.1) * (1 + rng.uniform(-0.1, 0.1) * xs)[..., None]
    if condition == "dusk":
        cast = (1.08, 0.97, 0.85) if rng.random() < 0.6 else (0.88, 0.96, 1.12)
        return img * rng.uniform(0.38, 0.6) * np.array(cast, np.float32)
    if condition == "night":
        ys = np.linspace(-1, 1, h, dtype=np.float32)[:, None]
        cx, cy = rng.uniform(-0.2, 0.3), rng.uniform(0.1, 0.5)
        spot = np.exp(-((xs - cx) ** 2 + (ys - cy) ** 2) / (2 * rng.uniform(0.5, 0.9) ** 2))
        out: NDArray[np.floating[Any]] = (
            img * (rng.uniform(0.04, 0.1) + rng.uniform(0.35, 0.7) * spot)[..., None]
        )
        for x, y, r in glow:  # the reflector returns the camera's light
            g = np.zeros((h, w), np.float32)
            cv2.circle(g, (x, y), r, 1.0, -1, cv2.LINE_AA)
            g = cv2.GaussianBlur(g, (0, 0), max(0.8, r * 0.6)) * rng.uniform(0.6, 1.0)
            out = out + g[..., None] * np.array([1.0, 0.55, 0.45], np.float32)
        return out
    if condition == "fog":
        a = rng.uniform(0.25, 0.5)
        return img * rng.uniform(0.75, 0.95) * (1 - a) + a * np.array(_SKY["fog"], np.float32)
    if condition == "snow":
        out = img * rng.uniform(0.8, 1.0)
        n = int(w * h / rng.uniform(250, 600))
        for x, y in zip(rng.integers(0, w, n), rng.integers(0, h, n), strict=True):
            cv2.circle(out, (int(x), int(y)), int(rng.integers(1, 3)), (0.95, 0.95, 0.97), -1)
        v = rng.uniform(0.08, 0.2)
        return out * (1 - v) + v * 0.9
    # rain: darker, streaks, a grey veil
    out = np.asarray(img * rng.uniform(0.55, 0.8), dtype=np.float32)
    streaks = np.zeros((h, w), np.float32)
    dx = int(rng.uniform(-0.3, 0.3) * h / 20)
    for x, y in zip(rng.integers(0, w, w // 3), rng.integers(0, h, w // 3), strict=True):
        cv2.line(streaks, (int(x), int(y)), (int(x) + dx, int(y) + h // 20), 1.0, 1)
    out = out * (1 - 0.2 * streaks[..., None]) + 0.2 * streaks[..., None] * 0.8
    return np.asarray(out * 0.92 + 0.08 * 0.5, dtype=np.float32)


def _light(
    rng: np.random.Generator, img: FloatImage, condition: str, glow: list[tuple[int, int, int]]
) -> FloatImage:
    """Light the scene for the condition (float RGB in, float32 RGB out)."""
    return np.asarray(_light_raw(rng, img, condition, glow), dtype=np.float32)


def _occlude(
    rng: np.random.Generator,
    img: FloatImage,
    centre: tuple[int, int] | None,
    radius: float,
    share: float,
) -> NDArray[np.bool_]:
    """A pole or signal post in front of the car; returns its mask."""
    h, w = img.shape[:2]
    mask = np.zeros((h, w), np.uint8)
    pw = max(2, int(w * rng.uniform(0.02, 0.05)))
    if centre is not None and share > 0:
        edge = int(centre[0] + radius * (1 - 2 * share))  # covers ≈ share of the width
        x0, x1 = edge, edge + pw + int(2 * radius)
    else:
        x0 = int(rng.uniform(0, w - pw))
        x1 = x0 + pw
    cv2.rectangle(mask, (x0, int(h * rng.uniform(0.0, 0.3))), (x1, h), 1, -1)
    colour = np.array([0.25, 0.25, 0.24], np.float32) * rng.uniform(0.5, 1.5)
    img[mask > 0] = colour * (1 + 0.1 * rng.standard_normal((int(mask.sum()), 1))).astype(
        np.float32
    )
    return mask > 0


def _camera(
    rng: np.random.Generator, img: FloatImage, condition: str, jpeg_quality: int | None
) -> NDArray[np.uint8]:
    h, w = img.shape[:2]
    cast = np.clip(rng.normal(1.0, 0.04, 3), 0.9, 1.1).astype(np.float32)
    out = img * cast
    if rng.random() < 0.35:
        length = max(2, int(rng.uniform(0.003, 0.012) * w))
        k = np.zeros((length, length), np.float32)
        cv2.line(k, (0, length // 2), (length - 1, length // 2), 1.0, 1)
        rot = cv2.getRotationMatrix2D(
            ((length - 1) / 2, (length - 1) / 2), rng.uniform(0, 180), 1.0
        )
        k = np.asarray(cv2.warpAffine(k, rot, (length, length)), np.float32)
        out = np.asarray(cv2.filter2D(out, -1, k / max(k.sum(), 1e-6)), np.float32)
    if rng.random() < 0.3:
        out = np.asarray(cv2.GaussianBlur(out, (0, 0), rng.uniform(0.4, 1.0) * w / 640), np.float32)
    sigma = rng.uniform(0.03, 0.06) if condition == "night" else rng.uniform(0.008, 0.03)
    out = out + rng.normal(0.0, sigma, out.shape).astype(np.float32)
    bgr = np.clip(out[..., ::-1] * 255.0 + 0.5, 0, 255).astype(np.uint8)
    q = int(jpeg_quality) if jpeg_quality is not None else int(rng.integers(35, 93))
    ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, q])
    if not ok:  # pragma: no cover - OpenCV always encodes a valid array
        raise RuntimeError("JPEG encoding failed")
    return np.asarray(cv2.imdecode(buf, cv2.IMREAD_COLOR), dtype=np.uint8)


def render_snapshot(
    seed_or_rng: int | np.random.Generator,
    *,
    disc: bool,
    condition: str,
    size: tuple[int, int] = (640, 480),
    car_colour: str | None = None,
    weak_disc: bool = False,
    distractors: tuple[str, ...] | None = None,
    occlusion: float | None = None,
    jpeg_quality: int | None = None,
) -> tuple[NDArray[np.uint8], SnapshotLabel]:
    """Render one labelled last-car snapshot.

    Parameters
    ----------
    seed_or_rng : int or numpy.random.Generator
        Seed (reproducible) or a generator to draw from.
    disc : bool
        Put a tail disc on the car.
    condition : {"day", "dusk", "night", "fog", "snow", "rain"}
    size : (width, height)
        Image size in pixels (at least 64×48).
    car_colour : str, optional
        A key of ``CAR_COLOURS``; random when omitted.
    weak_disc : bool
        A dirty, dull disc (harder to see, e.g. at night).
    distractors : tuple of str, optional
        Red non-disc objects (``DISTRACTORS``); random (often none) when omitted.
    occlusion : float, optional
        Share 0..0.5 of the disc hidden by a pole; ``0`` for none; random when omitted.
    jpeg_quality : int, optional
        JPEG quality 1..100; random 35..92 when omitted.

    Returns
    -------
    image_bgr : ndarray, shape (height, width, 3), uint8
    label : SnapshotLabel
    """
    if condition not in CONDITIONS:
        raise ValueError(f"unknown condition {condition!r}; use one of {CONDITIONS}")
    w, h = int(size[0]), int(size[1])
    if w < 64 or h < 48:
        raise ValueError(f"size must be at least 64x48 pixels, got {w}x{h}")
    if car_colour is not None and car_colour not in CAR_COLOURS:
        raise ValueError(f"unknown car colour {car_colour!r}; use one of {sorted(CAR_COLOURS)}")
    if occlusion is not None and not 0 <= occlusion <= 0.5:
        raise ValueError(f"occlusion must be in [0, 0.5], got {occlusion}")
    rng = _as_rng(seed_or_rng)
    colour_name = car_colour or str(rng.choice(list(CAR_COLOURS), p=_FLEET_SHARES))
    if distractors is None:
        n = int(rng.choice([0, 1, 2], p=[0.5, 0.35, 0.15]))
        distractors = tuple(str(d) for d in rng.choice(DISTRACTORS, n, replace=False))
    img = background(rng, h, w, _SKY[condition])
    geo = replace(draw_car(rng, img, CAR_COLOURS[colour_name]), disc_zone_taken=disc)
    for kind in distractors:
        draw_distractor(rng, img, geo, kind)
    mask = np.zeros((h, w), bool)
    centre, radius, glow = None, 0.0, []
    if disc:
        mask, centre, (refl_r, _rim), radius = draw_disc(rng, img, geo, weak=weak_disc)
        if condition == "night":
            glow.append((centre[0], centre[1], refl_r))
    img = _light(rng, img, condition, glow)
    share = (
        occlusion
        if occlusion is not None
        else (rng.uniform(0.05, 0.25) if rng.random() < 0.05 else 0.0)
    )
    visible = mask
    if share > 0 or rng.random() < 0.08:
        pole = _occlude(rng, img, centre if disc else None, radius, share if disc else 0.0)
        visible = mask & ~pole
    image = _camera(rng, img, condition, jpeg_quality)
    return image, _label(
        visible, mask, centre, radius, condition, colour_name, distractors, weak_disc
    )


def _label(
    visible: NDArray[np.bool_],
    mask: NDArray[np.bool_],
    centre: tuple[int, int] | None,
    radius: float,
    condition: str,
    colour: str,
    distractors: tuple[str, ...],
    weak: bool,
) -> SnapshotLabel:
    has_disc = bool(mask.any())
    bbox, ref = None, None
    if visible.any():
        ys, xs = np.nonzero(visible)
        bbox = (
            int(xs.min()),
            int(ys.min()),
            int(xs.max() - xs.min() + 1),
            int(ys.max() - ys.min() + 1),
        )
        # a point half-way between reflector and rim, on the visible side
        assert centre is not None
        for dx in (-0.55, 0.55):
            px, py = int(centre[0] + dx * radius), int(centre[1])
            if 0 <= py < visible.shape[0] and 0 <= px < visible.shape[1] and visible[py, px]:
                ref = (px, py)
                break
    occluded = 1.0 - float(visible.sum()) / float(mask.sum()) if has_disc else 0.0
    return SnapshotLabel(
        disc=has_disc,
        bbox=bbox,
        disc_fraction=float(visible.sum()) / visible.size,
        reference_point=ref,
        condition=condition,
        car_colour=colour,
        distractors=tuple(distractors),
        occluded=occluded,
        weak_disc=weak,
    )


def random_snapshot(
    seed_or_rng: int | np.random.Generator,
    *,
    size: tuple[int, int] = (640, 480),
    disc_share: float = 0.5,
) -> tuple[NDArray[np.uint8], SnapshotLabel]:
    """A snapshot with everything drawn at random (condition, car, disc with ``disc_share``)."""
    rng = _as_rng(seed_or_rng)
    condition = str(rng.choice(CONDITIONS, p=_CONDITION_WEIGHTS))
    return render_snapshot(
        rng,
        disc=bool(rng.random() < disc_share),
        condition=condition,
        size=size,
        weak_disc=bool(rng.random() < 0.1),
    )


def iter_snapshots(
    seed: int, count: int, *, size: tuple[int, int] = (640, 480)
) -> Iterator[tuple[NDArray[np.uint8], SnapshotLabel]]:
    """``count`` reproducible random snapshots (image ``i`` uses seed ``(seed, i)``)."""
    for i in range(count):
        yield random_snapshot(np.random.default_rng([seed, i]), size=size)


def write_study_set(
    directory: str | Path, count: int, *, seed: int = 0, size: tuple[int, int] = (640, 480)
) -> Path:
    """Write ``count`` snapshots as PNG files plus ``labels.csv`` into ``directory``.

    Returns the path of ``labels.csv``.
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    labels_path = out / "labels.csv"
    with labels_path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(LABEL_FIELDS)
        for i, (image, label) in enumerate(iter_snapshots(seed, count, size=size)):
            name = f"snap_{i:04d}.png"
            cv2.imwrite(str(out / name), image)
            x, y, bw, bh = label.bbox or ("", "", "", "")
            rx, ry = label.reference_point or ("", "")
            writer.writerow(
                [
                    name,
                    int(label.disc),
                    x,
                    y,
                    bw,
                    bh,
                    f"{label.disc_fraction:.6f}",
                    rx,
                    ry,
                    label.condition,
                    label.car_colour,
                    ";".join(label.distractors),
                    f"{label.occluded:.3f}",
                ]
            )
    return labels_path
