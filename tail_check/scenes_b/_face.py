"""A flat car face (end wall, side wall) drawn in metres, then warped into the image.

Faces are drawn frontally on a texture of ``ppm`` pixels per metre, so painted
letters, stripes and logos get the camera's perspective for free when the
texture is warped with the plane's homography.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from ._config import BGR, FloatImage, FloatMap

SHIFT = 3
"""Sub-pixel bits for OpenCV drawing (coordinates scaled by 2**SHIFT)."""


@dataclass
class Face:
    """Texture of a planar face: ``u0`` is the plane coordinate (metres) at
    column 0, ``top`` the height (metres above rail) at row 0; columns grow
    along the face, rows downwards."""

    width_m: float
    height_m: float
    ppm: float
    u0: float
    top: float
    texture: FloatImage = field(init=False)
    alpha: FloatMap = field(init=False)

    def __post_init__(self) -> None:
        w = max(4, int(np.ceil(self.width_m * self.ppm)))
        h = max(4, int(np.ceil(self.height_m * self.ppm)))
        self.texture = np.zeros((h, w, 3), np.float32)
        self.alpha = np.zeros((h, w), np.float32)

    def px(self, u: float, y: float) -> tuple[int, int]:
        """Plane point (metres) → fixed-point texture pixel for cv2 drawing."""
        col = (u - self.u0) * self.ppm * (1 << SHIFT)
        row = (self.top - y) * self.ppm * (1 << SHIFT)
        return int(round(col)), int(round(row))

    def length(self, metres: float) -> int:
        """Fixed-point length for cv2 radii."""
        return max(1, int(round(metres * self.ppm * (1 << SHIFT))))

    def thick(self, metres: float) -> int:
        """Line thickness in whole texture pixels (cv2 does not shift it)."""
        return max(1, int(round(metres * self.ppm)))

    def rect(self, u0: float, y0: float, u1: float, y1: float, colour: BGR,
             alpha: float = 1.0) -> None:
        """Filled axis-aligned rectangle between two plane corners."""
        self.poly([(u0, y0), (u1, y0), (u1, y1), (u0, y1)], colour, alpha)

    def poly(self, points: list[tuple[float, float]], colour: BGR, alpha: float = 1.0) -> None:
        """Filled polygon in plane metres."""
        pts = np.array([self.px(u, y) for u, y in points], np.int32).reshape(-1, 1, 2)
        cv2.fillPoly(self.texture, [pts], colour, cv2.LINE_AA, SHIFT)
        cv2.fillPoly(self.alpha, [pts], alpha, cv2.LINE_AA, SHIFT)

    def ellipse(self, u: float, y: float, ru: float, ry: float, colour: BGR,
                alpha: float = 1.0, thickness_m: float = 0.0) -> None:
        """Filled (or outlined when ``thickness_m > 0``) axis-aligned ellipse."""
        th = -1 if thickness_m <= 0 else self.thick(thickness_m)
        axes = (self.length(ru), self.length(ry))
        cv2.ellipse(self.texture, self.px(u, y), axes, 0, 0, 360, colour, th, cv2.LINE_AA, SHIFT)
        cv2.ellipse(self.alpha, self.px(u, y), axes, 0, 0, 360, alpha, th, cv2.LINE_AA, SHIFT)

    def line(self, a: tuple[float, float], b: tuple[float, float], colour: BGR,
             width_m: float, alpha: float = 1.0) -> None:
        """Straight bar of ``width_m`` metres."""
        th = self.thick(width_m)
        cv2.line(self.texture, self.px(*a), self.px(*b), colour, th, cv2.LINE_AA, SHIFT)
        cv2.line(self.alpha, self.px(*a), self.px(*b), alpha, th, cv2.LINE_AA, SHIFT)

    def text(self, u: float, y: float, label: str, height_m: float, colour: BGR,
             font: int = cv2.FONT_HERSHEY_SIMPLEX, weight: float = 0.14) -> None:
        """Painted text with its baseline-left at plane point (u, y)."""
        scale = height_m * self.ppm / 22.0  # Hershey capitals are ~22 px at scale 1
        th = max(1, int(round(height_m * self.ppm * weight)))
        (tw, tht), base = cv2.getTextSize(label, font, scale, th)
        col, row = self.px(u, y)
        x0, y0 = (col >> SHIFT) - th, (row >> SHIFT) - tht - th
        patch = np.zeros((tht + base + 2 * th, tw + 2 * th), np.uint8)
        # putText draws on 8-bit images only: draw a coverage patch, then blend it in
        cv2.putText(patch, label, (th, tht + th), font, scale, 255, th, cv2.LINE_AA)
        h, w = self.alpha.shape
        xa, ya = max(0, x0), max(0, y0)
        xb, yb = min(w, x0 + patch.shape[1]), min(h, y0 + patch.shape[0])
        if xa >= xb or ya >= yb:
            return
        cover = patch[ya - y0 : yb - y0, xa - x0 : xb - x0].astype(np.float32) / 255.0
        region = self.texture[ya:yb, xa:xb]
        paint = np.asarray(colour, np.float32)
        region[:] = region * (1.0 - cover[..., None]) + paint * cover[..., None]
        self.alpha[ya:yb, xa:xb] = np.maximum(self.alpha[ya:yb, xa:xb], cover)

    def text_width(self, label: str, height_m: float,
                   font: int = cv2.FONT_HERSHEY_SIMPLEX, weight: float = 0.14) -> float:
        """Width of ``label`` in metres when painted ``height_m`` high."""
        scale = height_m * self.ppm / 22.0
        th = max(1, int(round(height_m * self.ppm * weight)))
        (w, _), _ = cv2.getTextSize(label, font, scale, th)
        return float(w) / self.ppm

    def grime(self, rng: np.random.Generator, strength: float, scale_m: float) -> None:
        """Multiplicative dirt / weathering noise over the painted area."""
        h, w = self.alpha.shape
        step = scale_m * self.ppm
        cells = (max(2, int(h / step) + 1), max(2, int(w / step) + 1))
        small = rng.standard_normal(cells).astype(np.float32)
        big = cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)
        fine = rng.standard_normal((h, w)).astype(np.float32) * 0.25
        factor = np.clip(1.0 + strength * (big * 0.5 + fine), 0.4, 1.6)
        self.texture *= factor[..., None]

    def shade_rows(self, y_top: float, y_bottom: float, dark: float) -> None:
        """Darken towards ``y_bottom`` (road grime, underframe shadow)."""
        h = self.alpha.shape[0]
        ys = self.top - (np.arange(h, dtype=np.float32) + 0.5) / self.ppm
        t = np.clip((y_top - ys) / max(1e-3, y_top - y_bottom), 0.0, 1.0)
        self.texture *= (1.0 - dark * t)[:, None, None].astype(np.float32)
