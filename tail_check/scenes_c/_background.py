"""Sky, far scenery, ground, track and catenary for the C scenes."""

from __future__ import annotations

import numpy as np

from ._canvas import SKY_DEPTH, Cam, Canvas, jitter, noise_field, shade

FAR_Z = 160.0
SKY = {
    "daylight": ((235, 175, 120), (245, 225, 205)),
    "overcast": ((200, 196, 192), (225, 222, 220)),
    "dusk": ((120, 70, 60), (120, 150, 230)),
    "night": ((30, 14, 8), (55, 40, 35)),
    "rain": ((150, 145, 140), (185, 182, 180)),
    "snow": ((210, 205, 200), (235, 232, 230)),
    "fog": ((205, 205, 200), (215, 215, 212)),
}


def draw_sky(cv: Canvas, cam: Cam, cond: str, rng: np.random.Generator) -> None:
    top, hor = SKY[cond]
    hy = int(np.clip(cam.vy, 1, cv.h))
    t = np.linspace(0.0, 1.0, hy, dtype=np.float32)[:, None] ** 1.5
    grad = np.array(top, np.float32) * (1 - t[..., None]) + np.array(hor, np.float32) * t[..., None]
    sky = np.repeat(grad, cv.w, axis=1)
    if cond in ("daylight", "dusk", "overcast"):
        cloud = np.clip(noise_field(rng, cv.w, hy, cv.w / rng.uniform(4, 12)), 0, 1)
        sky = sky + cloud[..., None] * (np.array(hor, np.float32) - sky) * 0.9
    cv.img[:hy] = np.clip(sky + rng.normal(0, 1.5, sky.shape), 0, 255).astype(np.uint8)


def draw_far(cv: Canvas, cam: Cam, rng: np.random.Generator) -> None:
    """Treeline and buildings near the horizon."""
    style = rng.choice(["trees", "buildings", "mixed", "field"], p=[0.45, 0.2, 0.25, 0.1])
    base_y = cam.p(0, 0, FAR_Z)[1]
    if style in ("buildings", "mixed"):
        x = -50.0
        while x < cv.w + 50:
            bw = rng.uniform(0.05, 0.25) * cv.w
            bh = cam.scale(FAR_Z) * rng.uniform(6, 30)
            col = jitter(
                rng, tuple(rng.choice([(150, 160, 170), (120, 130, 140), (170, 190, 200)])), 0.2
            )
            pts = np.array([[x, base_y], [x + bw, base_y], [x + bw, base_y - bh], [x, base_y - bh]])
            cv.poly(pts.astype(np.float64), col, FAR_Z)
            for wy in np.arange(base_y - bh * 0.85, base_y - bh * 0.1, bh * 0.18):
                cv.line((x + bw * 0.08, wy), (x + bw * 0.92, wy), shade(col, 0.6), bh * 0.05)
            x += bw + rng.uniform(0, 0.1) * cv.w
    if style in ("trees", "mixed"):
        green = jitter(rng, (45, 85, 55), 0.3)
        n = int(cv.w / max(4.0, cam.scale(FAR_Z) * 3.0))
        for _ in range(min(n, 400)):
            x = rng.uniform(-20, cv.w + 20)
            r = cam.scale(FAR_Z) * rng.uniform(2.5, 7.0)
            top = base_y - r * rng.uniform(1.0, 2.6)
            cv.ellipse((x, top + r), (r, r * 1.4), 0, jitter(rng, green, 0.25), FAR_Z)
            cv.poly(
                np.array(
                    [[x - r, top + r], [x + r, top + r], [x + r, base_y], [x - r, base_y]],
                    np.float64,
                ),
                jitter(rng, green, 0.2),
                FAR_Z,
            )


def draw_ground(cv: Canvas, cam: Cam, rng: np.random.Generator, snowy: bool) -> None:
    y0 = int(np.clip(np.ceil(cam.vy), 0, cv.h))
    if y0 >= cv.h:
        return
    rows = np.arange(y0, cv.h, dtype=np.float32)
    z = cam.f * cam.hc / np.maximum(rows - cam.vy, 0.5)
    cv.depth[y0:] = np.minimum(z, FAR_Z)[:, None]
    base = np.array(jitter(rng, (70, 115, 105) if rng.random() < 0.6 else (85, 110, 125), 0.2))
    if snowy:
        base = np.array([225.0, 225.0, 222.0])
    tex = noise_field(rng, cv.w, cv.h - y0, rng.uniform(6, 25))
    fine = rng.normal(0, 1, (cv.h - y0, cv.w)).astype(np.float32)
    g = base[None, None, :] * (1 + 0.18 * tex[..., None] + 0.06 * fine[..., None])
    cv.img[y0:] = np.clip(g, 0, 255).astype(np.uint8)


def _quad(cam: Cam, x0: float, x1: float, y: float, z0: float, z1: float) -> np.ndarray:
    return cam.pts([(x0, y, z0), (x1, y, z0), (x1, y, z1), (x0, y, z1)])


def draw_track(
    cv: Canvas, cam: Cam, xt: float, rng: np.random.Generator, snowy: bool, main: bool
) -> None:
    """Ballast bed, sleepers and two rails of a track centred at lateral X = ``xt``."""
    zn = max(0.6, cam.f * cam.hc / max(cv.h - cam.vy, 1.0) * 0.8)
    zf = FAR_Z
    ballast = jitter(rng, (105, 110, 115), 0.2) if not snowy else (215.0, 215.0, 212.0)
    cv.poly(_quad(cam, xt - 2.2, xt + 2.2, 0.0, zn, zf), ballast, zf)
    concrete = rng.random() < 0.6
    sl_col = jitter(rng, (150, 150, 148) if concrete else (45, 55, 65), 0.15)
    if snowy:
        sl_col = shade(sl_col, 1.3)
    z = zn + rng.uniform(0, 0.55)
    while z < min(zf, 90.0):
        if cam.scale(z) * 0.25 > 0.7:
            cv.poly(_quad(cam, xt - 1.35, xt + 1.35, 0.05, z, z + 0.25), sl_col, z)
        z += 0.55
    rail_top = jitter(rng, (175, 178, 182), 0.1)
    for side in (-0.76, 0.76):
        x = xt + side
        cv.poly(_quad(cam, x - 0.04, x + 0.04, 0.16, zn, zf), (40.0, 45.0, 55.0), zf)
        a, b = cam.p(x, 0.17, zn), cam.p(x, 0.17, zf)
        cv.line(a, b, rail_top, max(1.0, cam.scale(zn) * 0.05))
    del main


def draw_poles(
    cv: Canvas, cam: Cam, xt: float, z0: float, rng: np.random.Generator, electrified: bool
) -> None:
    """Catenary poles beside the track beyond the car and the wires over the track."""
    if not electrified:
        return
    side = 1.0 if rng.random() < 0.5 else -1.0
    xp = xt + side * rng.uniform(3.0, 4.0)
    col = jitter(rng, (150, 150, 150) if rng.random() < 0.6 else (70, 80, 85), 0.15)
    z = z0 + rng.uniform(-10, 40)
    zs = []
    while z < FAR_Z:
        if z > 3.0:
            zs.append(z)
        z += rng.uniform(45, 65)
    for zp in sorted(zs, reverse=True):
        cv.poly(
            cam.pts(
                [(xp - 0.18, 0, zp), (xp + 0.18, 0, zp), (xp + 0.12, 8, zp), (xp - 0.12, 8, zp)]
            ),
            col,
            zp,
        )
        a, b = cam.p(xp, 7.2, zp), cam.p(xt - side * 0.3, 7.0, zp)
        cv.line(a, b, shade(col, 0.7), cam.scale(zp) * 0.1)
    wire = (40.0, 40.0, 45.0)
    for yw in (6.0, 7.1):
        a, b = cam.p(xt, yw, max(z0 * 0.35, 2.0)), cam.p(xt, yw, FAR_Z)
        cv.line(a, b, wire, 1)


def draw_scene_background(
    cv: Canvas, cam: Cam, cond: str, xt: float, z0: float, rng: np.random.Generator
) -> None:
    snowy = cond == "snow"
    draw_sky(cv, cam, cond, rng)
    draw_far(cv, cam, rng)
    draw_ground(cv, cam, rng, snowy)
    if rng.random() < 0.5:
        other = xt + (1 if rng.random() < 0.5 else -1) * rng.uniform(4.6, 5.3)
        draw_track(cv, cam, other, rng, snowy, False)
    draw_track(cv, cam, xt, rng, snowy, True)
    draw_poles(cv, cam, xt, z0, rng, rng.random() < 0.7)
    cv.depth[cv.depth >= SKY_DEPTH] = SKY_DEPTH
