"""Sky, ground, ballast, sleepers and rails, computed per pixel from ground rays.

Sleepers and rails are evaluated analytically in world coordinates with a
coverage that widens with the pixel footprint, so distant track fades into an
average colour instead of aliasing into moiré.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ._camera import Camera, Canvas
from ._config import BGR, FloatImage, FloatMap, Rng, f32, uniform


@dataclass(frozen=True)
class TrackGeometry:
    """Track dimensions in metres (1520 mm gauge; rail head centres)."""

    rail_half_gauge: float = 0.79
    rail_head_width: float = 0.075
    sleeper_half_length: float = 1.35
    sleeper_spacing: float = 0.54
    sleeper_width: float = 0.26
    ballast_half_width: float = 2.1
    neighbour_offset: float = 4.1


TRACK = TrackGeometry()


def _noise(rng: Rng, height: int, width: int, scale: float) -> FloatMap:
    """Smooth value noise in -1..1 with features of about ``scale`` pixels."""
    small = rng.standard_normal(
        (max(2, int(height / scale)) + 1, max(2, int(width / scale)) + 1)
    ).astype(np.float32)
    big = cv2.resize(small, (width, height), interpolation=cv2.INTER_CUBIC)
    return f32(np.clip(big / 2.0, -1.0, 1.0))


def paint_sky(canvas: Canvas, camera: Camera, rng: Rng, top: BGR, bottom: BGR) -> None:
    """Vertical sky gradient to the horizon, with soft clouds."""
    horizon = camera.horizon_row()
    rows = np.arange(canvas.height, dtype=np.float32)
    t = np.clip((rows - (horizon - canvas.height)) / max(1.0, canvas.height), 0.0, 1.0)
    col = (np.outer(1.0 - t, top) + np.outer(t, bottom)).astype(np.float32)
    sky = np.repeat(col[:, None, :], canvas.width, axis=1)
    clouds = np.clip(_noise(rng, canvas.height, canvas.width, canvas.height / 6.0), 0, 1)
    sky += (clouds * uniform(rng, (0.0, 50.0)))[..., None]
    canvas.albedo = sky.astype(np.float32)
    canvas.shade[:] = 1.0


def _coverage(distance: FloatMap, half_width: float, footprint: FloatMap) -> FloatMap:
    """Anti-aliased coverage of a band of ``half_width`` metres."""
    return f32(np.clip(0.5 + (half_width - distance) / footprint, 0.0, 1.0))


def _sleeper_cover(world_z: FloatMap, footprint: FloatMap) -> FloatMap:
    """Sleeper coverage along Z, averaged out where the footprint exceeds the spacing."""
    phase = f32(np.mod(world_z, TRACK.sleeper_spacing) - TRACK.sleeper_width / 2.0)
    phase = f32(np.minimum(np.abs(phase), TRACK.sleeper_spacing - np.abs(phase)))
    sharp = _coverage(phase, TRACK.sleeper_width / 2.0, footprint)
    mean = TRACK.sleeper_width / TRACK.sleeper_spacing
    fade = np.clip(footprint / TRACK.sleeper_spacing, 0.0, 1.0)
    return f32(sharp * (1.0 - fade) + mean * fade)


def _track_layer(
    albedo: FloatImage, wx: FloatMap, wz: FloatMap, fp: FloatMap, centre: float, rng: Rng,
    concrete: bool,
) -> FloatImage:
    """Paint one track (sleepers then rails) centred at world X ``centre``."""
    x = np.abs(wx - centre)
    sleeper_col = (150.0, 150.0, 145.0) if concrete else (45.0, 60.0, 75.0)
    across = _coverage(x, TRACK.sleeper_half_length, fp)
    cover = (across * _sleeper_cover(wz, fp))[..., None]
    albedo = albedo * (1.0 - cover) + np.asarray(sleeper_col, np.float32) * cover
    rail = _coverage(np.abs(x - TRACK.rail_half_gauge), TRACK.rail_head_width / 2.0, fp)
    head = _coverage(np.abs(x - TRACK.rail_half_gauge), TRACK.rail_head_width / 5.0, fp)
    shine = uniform(rng, (150.0, 215.0))
    rail_col = np.asarray((55.0, 62.0, 70.0), np.float32)
    albedo = albedo * (1.0 - rail[..., None]) + rail_col * rail[..., None]
    albedo = albedo + (shine - 60.0) * head[..., None] * 0.8
    return f32(albedo)


def paint_ground(canvas: Canvas, camera: Camera, rng: Rng, verge: BGR, snowy: bool) -> None:
    """Verge (grass, soil or snow), ballast bed, sleepers and rails of the track."""
    wx, wz, depth = camera.ground_rays()
    ground = np.isfinite(depth)
    wx = np.where(ground, wx, 0.0).astype(np.float32)  # sky pixels: keep the maths finite
    wz = np.where(ground, wz, 0.0).astype(np.float32)
    fp = np.where(ground, depth / camera.focal * 1.5, 1.0).astype(np.float32)
    h, w = canvas.height, canvas.width
    grain = _noise(rng, h, w, 3.0) * 0.6 + _noise(rng, h, w, 12.0) * 0.4
    fade = np.clip(1.0 - depth / 60.0, 0.15, 1.0)
    ballast = np.asarray((118.0, 120.0, 124.0) if not snowy else (225.0, 225.0, 230.0), np.float32)
    ballast = ballast * uniform(rng, (0.7, 1.1))
    bed = _coverage(np.abs(wx), TRACK.ballast_half_width, fp * 4.0)[..., None]
    verge_col = np.asarray(verge, np.float32)
    albedo = verge_col * (1.0 - bed) + ballast * bed
    albedo = albedo * (1.0 + (grain * 0.35 * fade)[..., None])
    concrete = bool(rng.random() < 0.6)
    albedo = _track_layer(albedo.astype(np.float32), wx, wz, fp, 0.0, rng, concrete)
    if rng.random() < 0.5:
        side = 1.0 if rng.random() < 0.5 else -1.0
        albedo = _track_layer(albedo, wx, wz, fp, side * TRACK.neighbour_offset, rng, concrete)
    if snowy:
        drift = np.clip(_noise(rng, h, w, 8.0) + 0.4, 0.0, 1.0)[..., None]
        albedo = albedo * (1.0 - drift) + np.float32(232.0) * drift
    canvas.albedo = np.where(ground[..., None], albedo, canvas.albedo).astype(np.float32)
    canvas.depth = np.where(ground, depth, canvas.depth).astype(np.float32)
