"""Lineside scenery: tree lines, buildings, a station platform, catenary poles and wires."""

from __future__ import annotations

import cv2
import numpy as np

from ._camera import Camera, Canvas
from ._config import BGR, Rng, f32, hsv_to_bgr, uniform

BACKGROUNDS: tuple[str, ...] = ("trees", "buildings", "station", "open")


def _row_at_depth(camera: Camera, depth: float) -> float:
    """Image row of the ground straight ahead at camera depth ``depth`` (metres)."""
    fwd = camera.rot[2]
    flat = np.array([fwd[0], 0.0, fwd[2]]) / np.hypot(fwd[0], fwd[2])
    point = camera.pos + flat * depth
    point[1] = 0.0
    return float(camera.project(point[None, :])[0, 1])


def tree_line(canvas: Canvas, camera: Camera, rng: Rng, green: BGR) -> None:
    """A ragged band of trees standing on the ground far away."""
    depth = uniform(rng, (40.0, 160.0))
    base = _row_at_depth(camera, depth)
    px_per_m = camera.focal / depth
    w = canvas.width
    walk = np.cumsum(rng.normal(0.0, 0.35, w // 4 + 2))
    heights = uniform(rng, (8.0, 20.0)) + 3.0 * (walk - walk.mean()) / (walk.std() + 1e-6)
    heights = np.interp(np.arange(w), np.arange(len(heights)) * 4, heights)
    top = base - np.clip(heights, 3.0, 30.0) * px_per_m
    rows = np.arange(canvas.height, dtype=np.float32)[:, None]
    inside = ((rows >= top[None, :]) & (rows <= base + 2)).astype(np.float32)
    mask = np.asarray(cv2.GaussianBlur(inside, (3, 3), 0), np.float32)
    leaves = rng.standard_normal((canvas.height // 6 + 1, w // 6 + 1)).astype(np.float32)
    leaves = f32(cv2.resize(leaves, (w, canvas.height), interpolation=cv2.INTER_LINEAR))
    colour = np.asarray(green, np.float32) * (1.0 + 0.3 * leaves[..., None])
    canvas.paint(mask, colour.astype(np.float32), depth)


def buildings(canvas: Canvas, camera: Camera, rng: Rng) -> None:
    """A few blocky buildings with window grids on the horizon."""
    for _ in range(int(rng.integers(2, 6))):
        depth = uniform(rng, (50.0, 200.0))
        base = _row_at_depth(camera, depth)
        ppm = camera.focal / depth
        bw, bh = uniform(rng, (10.0, 40.0)) * ppm, uniform(rng, (6.0, 30.0)) * ppm
        x0 = uniform(rng, (-0.2, 1.0)) * canvas.width
        wall = hsv_to_bgr(uniform(rng, (5.0, 30.0)), uniform(rng, (0.0, 70.0)),
                          uniform(rng, (90.0, 210.0)))  # plaster, cream, brick, concrete
        poly = np.array([(x0, base), (x0 + bw, base), (x0 + bw, base - bh), (x0, base - bh)])
        canvas.paint_polygon(poly, wall, depth)
        glass = (max(0.0, wall[0] * 0.5), wall[1] * 0.5, wall[2] * 0.45)
        step = 3.2 * ppm
        if step < 3:
            continue
        for row in np.arange(base - bh + step * 0.5, base - step * 0.6, step):
            for col in np.arange(x0 + step * 0.4, x0 + bw - step * 0.6, step):
                win = np.array([(col, row), (col + step * 0.5, row),
                                (col + step * 0.5, row + step * 0.5), (col, row + step * 0.5)])
                canvas.paint_polygon(win, glass, depth)


def station(canvas: Canvas, camera: Camera, rng: Rng, side: float, z_far: float) -> None:
    """A low platform beside the track with canopy pillars."""
    edge, far = side * 1.92, side * 9.0
    y = uniform(rng, (0.2, 1.1))
    stone = hsv_to_bgr(0.0, 0.0, uniform(rng, (110.0, 190.0)))
    top = np.asarray([(edge, y, 2.0), (far, y, 2.0), (far, y, z_far), (edge, y, z_far)])
    canvas.paint_polygon(camera.project_polygon(top), stone, 30.0)
    front = np.asarray([(edge, 0.0, 2.0), (edge, y, 2.0), (edge, y, z_far), (edge, 0.0, z_far)])
    canvas.paint_polygon(camera.project_polygon(front), (stone[0] * 0.6,) * 3, 30.0)
    a, b = edge + side * 0.5, edge + side * 0.6  # the yellow safety line
    line = np.asarray([(a, y, 2.0), (b, y, 2.0), (b, y, z_far), (a, y, z_far)])
    canvas.paint_polygon(camera.project_polygon(line), (40.0, 200.0, 230.0), 30.0)
    for z in np.arange(uniform(rng, (8.0, 20.0)), z_far, uniform(rng, (8.0, 14.0))):
        x = side * 5.0
        pillar = np.asarray([(x - 0.15, y, z), (x + 0.15, y, z), (x + 0.15, 4.5, z),
                             (x - 0.15, 4.5, z)])
        canvas.paint_polygon(camera.project_polygon(pillar), (70.0, 75.0, 80.0),
                             camera.depth((x, 2.0, float(z))))


def catenary(canvas: Canvas, camera: Camera, rng: Rng, z_end: float, front: bool) -> None:
    """Catenary masts beyond (``front=False``) or before (``front=True``) the car's end,
    and the contact and messenger wires (drawn with the far pass)."""
    spacing = uniform(rng, (45.0, 65.0))
    z0 = float(rng.uniform(5.0, spacing))
    side = 1.0 if rng.random() < 0.5 else -1.0
    x = side * uniform(rng, (3.1, 3.6))
    concrete = hsv_to_bgr(0.0, 0.0, uniform(rng, (80.0, 170.0)))
    for z in np.arange(z0, 400.0, spacing):
        if (z < z_end) != front:
            continue
        w = 0.18
        mast = np.asarray([(x - w, 0.0, z), (x + w, 0.0, z), (x + w * 0.7, 8.5, z),
                           (x - w * 0.7, 8.5, z)])
        depth = camera.depth((x, 4.0, float(z)))
        canvas.paint_polygon(camera.project_polygon(mast), concrete, depth)
        arm = np.asarray([(x, 7.2, z), (0.0, 6.9, z), (0.0, 7.0, z), (x, 7.35, z)])
        canvas.paint_polygon(camera.project_polygon(arm), (50.0, 50.0, 55.0), depth)
    if not front:
        _wires(canvas, camera)


def _wires(canvas: Canvas, camera: Camera) -> None:
    """Contact and messenger wires along the track, thin dark polylines."""
    zs = np.linspace(2.0, 600.0, 300)
    for y in (6.0, 7.3):
        pts = np.stack([np.zeros_like(zs), np.full_like(zs, y), zs], axis=1)
        cam = camera.to_camera(pts)
        img = camera.project(pts[cam[:, 2] > 1.0])
        mask = np.zeros((canvas.height, canvas.width), np.uint8)
        cv2.polylines(mask, [np.round(img * 4).astype(np.int32).reshape(-1, 1, 2)], False, 255,
                      2, cv2.LINE_AA, 2)
        canvas.paint(mask.astype(np.float32) / 255.0 * 0.8, (40.0, 40.0, 45.0), 200.0)
