"""Drawing surface and a pinhole camera for the C scene generator."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

U8 = npt.NDArray[np.uint8]
F32 = npt.NDArray[np.float32]
I32 = npt.NDArray[np.int32]
Colour = tuple[float, float, float]
P3 = tuple[float, float, float]

SHIFT = 4
SCALE = float(1 << SHIFT)
SKY_DEPTH = 1.0e6


@dataclass(frozen=True)
class Cam:
    """Pinhole camera looking along +Z; Y is height above the rail head plane."""

    f: float
    vx: float
    vy: float
    hc: float

    def p(self, x: float, y: float, z: float) -> tuple[float, float]:
        z = max(z, 0.05)
        return (self.vx + self.f * x / z, self.vy + self.f * (self.hc - y) / z)

    def pts(self, pts3: Sequence[P3]) -> npt.NDArray[np.float64]:
        return np.array([self.p(x, y, z) for x, y, z in pts3], dtype=np.float64)

    def scale(self, z: float) -> float:
        return self.f / max(z, 0.05)


@dataclass
class Canvas:
    img: U8
    depth: F32
    glow: F32

    @property
    def h(self) -> int:
        return int(self.img.shape[0])

    @property
    def w(self) -> int:
        return int(self.img.shape[1])

    def poly(self, pts: npt.NDArray[np.float64], colour: Colour, z: float) -> None:
        fixed = np.round(pts * SCALE).astype(np.int32).reshape(-1, 1, 2)
        cv2.fillPoly(self.img, [fixed], colour, cv2.LINE_AA, SHIFT)
        cv2.fillPoly(self.depth, [fixed], (float(z),), cv2.LINE_8, SHIFT)

    def line(
        self, a: tuple[float, float], b: tuple[float, float], colour: Colour, thick: float
    ) -> None:
        pa = (int(round(a[0] * SCALE)), int(round(a[1] * SCALE)))
        pb = (int(round(b[0] * SCALE)), int(round(b[1] * SCALE)))
        cv2.line(self.img, pa, pb, colour, max(1, int(round(thick))), cv2.LINE_AA, SHIFT)

    def ellipse(
        self,
        centre: tuple[float, float],
        axes: tuple[float, float],
        angle: float,
        colour: Colour,
        z: float,
    ) -> None:
        c = (int(round(centre[0] * SCALE)), int(round(centre[1] * SCALE)))
        ax = (max(1, int(round(axes[0] * SCALE))), max(1, int(round(axes[1] * SCALE))))
        cv2.ellipse(self.img, c, ax, angle, 0, 360, colour, -1, cv2.LINE_AA, SHIFT)
        cv2.ellipse(self.depth, c, ax, angle, 0, 360, (float(z),), -1, cv2.LINE_8, SHIFT)

    def add_glow(self, centre: tuple[float, float], radius: float, colour: Colour) -> None:
        """Add a soft emissive blob (values in 0-255 units) to the glow layer."""
        r = max(radius, 1.0)
        x0, x1 = int(max(0, centre[0] - 4 * r)), int(min(self.w, centre[0] + 4 * r + 1))
        y0, y1 = int(max(0, centre[1] - 4 * r)), int(min(self.h, centre[1] + 4 * r + 1))
        if x1 <= x0 or y1 <= y0:
            return
        yy, xx = np.mgrid[y0:y1, x0:x1].astype(np.float32)
        d2 = ((xx - centre[0]) ** 2 + (yy - centre[1]) ** 2) / (r * r)
        blob = np.exp(-d2 * 1.2).astype(np.float32)
        self.glow[y0:y1, x0:x1] += blob[..., None] * np.array(colour, dtype=np.float32)


def new_canvas(w: int, h: int) -> Canvas:
    return Canvas(
        img=np.zeros((h, w, 3), dtype=np.uint8),
        depth=np.full((h, w), SKY_DEPTH, dtype=np.float32),
        glow=np.zeros((h, w, 3), dtype=np.float32),
    )


def circle3(cx: float, cy: float, z: float, r: float, n: int = 32, plane: str = "z") -> list[P3]:
    """Points of a circle; plane "z" = frontal (constant Z), "x" = side (constant X)."""
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    if plane == "z":
        return [(cx + r * float(np.cos(a)), cy + r * float(np.sin(a)), z) for a in t]
    return [(cx, cy + r * float(np.sin(a)), z + r * float(np.cos(a))) for a in t]


def noise_field(rng: np.random.Generator, w: int, h: int, cell: float) -> F32:
    """Smooth noise in about [-1, 1] with features of roughly ``cell`` pixels."""
    gw, gh = max(2, int(w / max(cell, 1.0)) + 2), max(2, int(h / max(cell, 1.0)) + 2)
    small = rng.standard_normal((gh, gw)).astype(np.float32)
    big = cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)
    return np.asarray(np.clip(big * 0.6, -1.0, 1.0), dtype=np.float32)


def jitter(rng: np.random.Generator, c: Colour, amount: float) -> Colour:
    v = np.array(c) * (1.0 + rng.uniform(-amount, amount)) + rng.uniform(-8, 8, 3)
    out = np.clip(v, 0, 255)
    return (float(out[0]), float(out[1]), float(out[2]))


def shade(c: Colour, k: float) -> Colour:
    return (min(255.0, c[0] * k), min(255.0, c[1] * k), min(255.0, c[2] * k))
