"""Pinhole camera of a trackside mast, and the canvas the scene is painted on.

World frame: X to the right as seen from the camera, Y up from rail top, Z
along the track away from the camera (metres). The camera has no roll, so the
horizon is a horizontal image row; the final mild rotation is applied to the
whole image later (:mod:`._camera_fx`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt

from ._config import BGR, FloatImage, FloatMap, f32

Vec3 = tuple[float, float, float]
Points = npt.NDArray[np.float64]
"""N×3 world points (metres) or N×2 image points (pixels)."""

NEAR_Z = 0.3
"""Closest camera depth kept when clipping polygons (metres)."""


@dataclass(frozen=True)
class Camera:
    """Pinhole camera: focal length in pixels, centre, position and rotation.

    ``rot`` rows are the camera's right, down and forward axes in world
    coordinates; ``pos`` is the camera centre in metres.
    """

    width: int
    height: int
    focal: float
    pos: Points
    rot: Points

    @staticmethod
    def looking_at(width: int, height: int, focal: float, pos: Vec3, target: Vec3) -> Camera:
        """Camera at ``pos`` aimed at ``target`` with a level horizon."""
        eye = np.asarray(pos, dtype=np.float64)
        forward = np.asarray(target, dtype=np.float64) - eye
        forward /= np.linalg.norm(forward)
        right = np.cross(np.array([0.0, 1.0, 0.0]), forward)
        right /= np.linalg.norm(right)
        down = -np.cross(forward, right)
        down /= np.linalg.norm(down)
        return Camera(width, height, focal, eye, np.stack([right, down, forward]))

    @property
    def k_matrix(self) -> Points:
        """3×3 intrinsic matrix."""
        return np.array(
            [
                [self.focal, 0.0, self.width / 2.0],
                [0.0, self.focal, self.height / 2.0],
                [0.0, 0.0, 1.0],
            ]
        )

    def to_camera(self, points: Points) -> Points:
        """World N×3 → camera N×3 (x right, y down, z forward)."""
        result: Points = (np.asarray(points, dtype=np.float64) - self.pos) @ self.rot.T
        return result

    def project(self, points: Points) -> Points:
        """World N×3 → image N×2 pixels (points must be in front of the camera)."""
        cam = self.to_camera(points)
        z = np.maximum(cam[:, 2], 1e-6)
        u = self.focal * cam[:, 0] / z + self.width / 2.0
        v = self.focal * cam[:, 1] / z + self.height / 2.0
        result: Points = np.stack([u, v], axis=1)
        return result

    def depth(self, point: Vec3) -> float:
        """Camera depth (metres along the optical axis) of one world point."""
        return float(self.to_camera(np.asarray([point]))[0, 2])

    def plane_homography(self, origin: Vec3, axis_u: Vec3, axis_v: Vec3, ppm: float) -> Points:
        """Homography from a texture of ``ppm`` pixels per metre to the image.

        Texture pixel (i, j) sits at world ``origin + axis_u*i/ppm + axis_v*j/ppm``.
        """
        cols = np.stack(
            [
                np.asarray(axis_u, dtype=np.float64) / ppm,
                np.asarray(axis_v, dtype=np.float64) / ppm,
                np.asarray(origin, dtype=np.float64) - self.pos,
            ],
            axis=1,
        )
        result: Points = self.k_matrix @ self.rot @ cols
        normalised: Points = result / result[2, 2]
        return normalised

    def project_polygon(self, points: Points) -> Points | None:
        """Project a planar world polygon, clipped to ``z > NEAR_Z``; None if gone."""
        cam = self.to_camera(points)
        kept: list[npt.NDArray[np.float64]] = []
        count = len(cam)
        for index in range(count):
            cur, nxt = cam[index], cam[(index + 1) % count]
            if cur[2] > NEAR_Z:
                kept.append(cur)
            if (cur[2] > NEAR_Z) != (nxt[2] > NEAR_Z):
                t = (NEAR_Z - cur[2]) / (nxt[2] - cur[2])
                kept.append(cur + t * (nxt - cur))
        if len(kept) < 3:
            return None
        clipped = np.stack(kept)
        u = self.focal * clipped[:, 0] / clipped[:, 2] + self.width / 2.0
        v = self.focal * clipped[:, 1] / clipped[:, 2] + self.height / 2.0
        return np.stack([u, v], axis=1)

    def ground_rays(self) -> tuple[FloatMap, FloatMap, FloatMap]:
        """Per-pixel ground hit: world X, world Z and camera depth (inf above horizon)."""
        us, vs = np.meshgrid(
            np.arange(self.width, dtype=np.float32), np.arange(self.height, dtype=np.float32)
        )
        dx = (us - self.width / 2.0) / self.focal
        dy = (vs - self.height / 2.0) / self.focal
        rot = self.rot.astype(np.float32)
        ray = [dx * rot[0, k] + dy * rot[1, k] + rot[2, k] for k in range(3)]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(ray[1] < -1e-5, -float(self.pos[1]) / ray[1], np.inf).astype(np.float32)
            # sky pixels (t = inf) give inf or nan here; callers mask them with isfinite(t)
            world_x = (float(self.pos[0]) + t * ray[0]).astype(np.float32)
            world_z = (float(self.pos[2]) + t * ray[2]).astype(np.float32)
        return world_x, world_z, t

    def horizon_row(self) -> float:
        """Image row of the horizon (may lie outside the image)."""
        fwd = self.rot[2]
        horizontal = np.array([fwd[0], 0.0, fwd[2]])
        far = self.pos + 1e6 * horizontal / np.linalg.norm(horizontal)
        return float(self.project(far[None, :])[0, 1])


@dataclass
class Canvas:
    """Albedo, emission and depth buffers of one scene, painted back to front.

    ``albedo`` is lit later by the condition's light; ``emission`` (lamps,
    lit reflectors) is added after lighting; ``depth`` (metres, inf for sky)
    drives fog and headlight fall-off.
    """

    width: int
    height: int
    albedo: FloatImage = field(init=False)
    emission: FloatImage = field(init=False)
    depth: FloatMap = field(init=False)
    shade: FloatMap = field(init=False)

    def __post_init__(self) -> None:
        self.albedo = np.zeros((self.height, self.width, 3), np.float32)
        self.emission = np.zeros((self.height, self.width, 3), np.float32)
        self.depth = np.full((self.height, self.width), np.inf, np.float32)
        self.shade = np.ones((self.height, self.width), np.float32)

    def paint(self, mask: FloatMap, colour: FloatImage | BGR, depth: float | FloatMap,
              shade: float = 1.0) -> None:
        """Alpha-blend ``colour`` where ``mask`` (0..1) is set; write its depth.

        ``colour`` and ``depth`` are either per-pixel (full image) or constant.
        Only the mask's bounding box is touched, which keeps small items cheap.
        """
        x, y, w, h = cv2.boundingRect((mask > 1e-3).astype(np.uint8))
        if w == 0 or h == 0:
            return
        box = (slice(y, y + h), slice(x, x + w))
        col = np.asarray(colour, dtype=np.float32)
        dep: float | FloatMap = (
            float(depth) if isinstance(depth, float | int) else np.asarray(depth, np.float32)[box]
        )
        self._blend(box, mask[box], col[box] if col.ndim == 3 else col, dep, shade)

    def _blend(self, box: tuple[slice, slice], alpha: FloatMap, col: npt.NDArray[np.float32],
               depth: float | FloatMap, shade: float) -> None:
        """Blend inside ``box``; ``alpha`` (and per-pixel ``col``/``depth``) are box-sized."""
        region = self.albedo[box]
        region[:] = region * (1.0 - alpha[..., None]) + col * alpha[..., None]
        self.emission[box] *= (1.0 - alpha)[..., None]  # what is painted over a lamp hides it
        solid = alpha > 0.5
        self.depth[box][solid] = depth if isinstance(depth, float) else depth[solid]
        self.shade[box][solid] = shade

    def paint_polygon(self, poly: Points | None, colour: BGR, depth: float,
                      shade: float = 1.0, alpha: float = 1.0) -> None:
        """Fill an image polygon (anti-aliased) with a flat colour."""
        if poly is None:
            return
        x0 = max(0, int(np.floor(poly[:, 0].min())) - 1)
        y0 = max(0, int(np.floor(poly[:, 1].min())) - 1)
        x1 = min(self.width, int(np.ceil(poly[:, 0].max())) + 2)
        y1 = min(self.height, int(np.ceil(poly[:, 1].max())) + 2)
        if x0 >= x1 or y0 >= y1:
            return
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        pts = np.round((poly - [x0, y0]) * 4.0).astype(np.int32).reshape(-1, 1, 2)
        cv2.fillPoly(mask, [pts], 255, lineType=cv2.LINE_AA, shift=2)
        box = (slice(y0, y1), slice(x0, x1))
        cover = mask.astype(np.float32) * np.float32(alpha / 255.0)
        self._blend(box, cover, np.asarray(colour, np.float32), depth, shade)

    def paste(self, texture: FloatImage, alpha: FloatMap, homography: Points,
              depth: float | FloatMap, shade: float = 1.0) -> FloatMap:
        """Warp a texture with alpha into the image; returns the warped alpha."""
        size = (self.width, self.height)
        warped = cv2.warpPerspective(texture, homography, size, flags=cv2.INTER_LINEAR)
        mask = cv2.warpPerspective(alpha, homography, size, flags=cv2.INTER_LINEAR)
        self.paint(f32(mask), f32(warped), depth, shade)
        return f32(mask)
