"""Paint a :class:`~._layout.Layout`: background, car faces, disc, negatives, light, camera."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import _negatives as neg
from ._camera import Camera, Canvas
from ._car import BEAM_TOP, CarSpec, choose_car, draw_end, draw_side
from ._config import RANGES, FloatMap, Rng, f32, hsv_to_bgr, uniform
from ._disc import TEXTURE_PX, choose_look, render_disc
from ._face import Face
from ._layout import Layout
from ._light import Light, choose_light, light_scene, precipitation
from ._scenery import buildings, catenary, station, tree_line
from ._sensor import Uint8Image, jpeg_round_trip, optics, sensor, tilt

MAX_TEXTURE_PX = 2400
"""Largest side of a face texture; beyond it the face is drawn a little softer."""


def _background(canvas: Canvas, lay: Layout, light: Light, rng: Rng) -> None:
    from ._ground import paint_ground, paint_sky

    cam = lay.camera
    paint_sky(canvas, cam, rng, light.sky_top, light.sky_bottom)
    if lay.background in ("trees", "station"):
        tree_line(canvas, cam, rng, light.tree)
    if lay.background in ("buildings", "station"):
        buildings(canvas, cam, rng)
    paint_ground(canvas, cam, rng, light.verge, light.snowy)
    if lay.background == "station":
        station(canvas, cam, rng, -float(np.sign(cam.pos[0])), lay.end_z + 60.0)
    if rng.random() < 0.6:
        catenary(canvas, cam, rng, lay.end_z, front=False)


def _faces(lay: Layout) -> tuple[Face, Face]:
    """End and side face textures at a resolution matching their image scale."""
    car = lay.car
    top = car.top + (2.7 if car.container is not None else 0.1)
    ppm = min(lay.camera.focal / max(lay.end_z, 1.0) * 1.25, MAX_TEXTURE_PX / top)
    end = Face(car.width + 0.1, top, ppm, -(car.width / 2 + 0.05), top)
    side = Face(car.length, top, min(ppm, MAX_TEXTURE_PX / car.length), 0.0, top)
    return end, side


def _letter_height(lay: Layout, rng: Rng) -> float:
    """Metres of a letter 5–10 % of the image height at the end wall's distance."""
    return uniform(rng, (0.05, 0.1)) * lay.height * lay.end_z / lay.camera.focal


def _paint_markings(lay: Layout, end: Face, side: Face, tail_u: float, rng: Rng) -> None:
    """White running numbers always; the red painted negatives when chosen."""
    car = lay.car
    white = hsv_to_bgr(0.0, 0.0, uniform(rng, (190.0, 240.0)))
    number = "".join(str(int(d)) for d in rng.integers(0, 10, 8))
    u = tail_u + 0.6 if tail_u < 1 else tail_u - 0.6 - side.text_width(number, 0.22)
    if car.top > 2.5:
        side.text(u, min(car.top - 0.6, 2.9), number, 0.22, white)
    kinds = [k for k in (lay.negative_kind, *lay.extras) if k is not None]
    for kind in kinds:
        on_end = rng.random() < 0.5
        face, tu = (end, 0.0) if on_end else (side, tail_u)
        if kind == "red_lettering":
            neg.red_lettering(face, car, rng, min(_letter_height(lay, rng), 0.9), tu)
        elif kind == "red_stripe":
            neg.red_stripe(end, car, rng)
            neg.red_stripe(side, car, rng)
        elif kind == "red_logo":
            neg.red_logo(face, car, rng, uniform(rng, (0.5, 1.3)), tu)
        elif kind == "hand_wheel":
            neg.hand_wheel(end, car, rng, -float(np.sign(lay.disc_pos[0])))
    if lay.stripe_beside_disc and lay.disc:
        y = lay.disc_pos[1] + uniform(rng, (-0.3, 0.5))
        neg.red_stripe(end, car, rng, y=max(BEAM_TOP + 0.02, y))


def _paste_side(canvas: Canvas, cam: Camera, car: CarSpec, face: Face, z_start: float,
                shade: float) -> None:
    """Warp one car's side wall (facing the camera) into the image, with its depth."""
    import cv2

    sgn = float(np.sign(cam.pos[0])) or 1.0
    if sgn > 0:
        hom = cam.plane_homography((car.width / 2, face.top, z_start), (0, 0, 1), (0, -1, 0),
                                   face.ppm)
    else:
        hom = cam.plane_homography((-car.width / 2, face.top, z_start + car.length),
                                   (0, 0, -1), (0, -1, 0), face.ppm)
    h, w = face.alpha.shape
    us = (np.arange(w) + 0.5) / face.ppm
    zs = z_start + (us if sgn > 0 else car.length - us)
    pts = np.stack([np.full(w, sgn * car.width / 2), np.full(w, 2.0), zs], axis=1)
    depth_tex = np.repeat(f32(cam.to_camera(pts)[:, 2])[None, :], h, axis=0)
    depth = f32(cv2.warpPerspective(depth_tex, hom, (canvas.width, canvas.height),
                                    flags=cv2.INTER_NEAREST))
    canvas.paste(face.texture, face.alpha, hom, depth, shade=shade)


def _train_ahead(canvas: Canvas, lay: Layout, shade: float, rng: Rng) -> float:
    """The cars coupled ahead of the last one, far to near; returns the train's far end Z."""
    cars = []
    z = lay.end_z + lay.car.length + uniform(rng, (0.9, 1.3))
    for _ in range(int(rng.integers(0, 4))):
        same = rng.random() < 0.6  # block trains: the same car type over and over
        car = replace(lay.car, length=uniform(rng, (12.0, 19.0))) if same else choose_car(
            rng, red_body=False)
        cars.append((car, z))
        z += car.length + uniform(rng, (0.9, 1.3))
    for car, z0 in reversed(cars):
        top = car.top + (2.7 if car.container is not None else 0.1)
        ppm = min(lay.camera.focal / z0 * 1.25, MAX_TEXTURE_PX / car.length)
        face = Face(car.length, top, ppm, 0.0, top)
        draw_side(face, car, rng)
        _paste_side(canvas, lay.camera, car, face, z0, shade)
    return z


def _paste_car(canvas: Canvas, lay: Layout, light: Light, rng: Rng) -> None:
    """Shadow, the train ahead, the last car's side wall, then its end wall (nearer)."""
    cam, car = lay.camera, lay.car
    shade = float(np.clip(light.side_shade, 0.5, 1.4))
    far = _train_ahead(canvas, lay, shade, rng)
    half = car.width / 2 + 0.25
    shadow = np.asarray([(-half, 0.0, lay.end_z - 0.3), (half, 0.0, lay.end_z - 0.3),
                         (half, 0.0, far), (-half, 0.0, far)])
    canvas.paint_polygon(cam.project_polygon(shadow), (10.0, 10.0, 12.0),
                         cam.depth((0.0, 0.0, lay.end_z)), alpha=uniform(rng, (0.25, 0.55)))
    end, side = _faces(lay)
    tail_u = 0.0 if cam.pos[0] >= 0 else car.length
    draw_side(side, car, rng)
    draw_end(end, car, rng)
    _paint_markings(lay, end, side, tail_u, rng)
    x, y, _ = lay.disc_pos
    end.line((x, BEAM_TOP - 0.05), (x, y), (40.0, 40.0, 42.0), 0.05)  # disc bracket
    end.rect(x - 0.07, BEAM_TOP - 0.02, x + 0.07, BEAM_TOP + 0.06, (45.0, 45.0, 48.0))
    _paste_side(canvas, cam, car, side, lay.end_z, shade)
    hom = cam.plane_homography((end.u0, end.top, lay.end_z), (1, 0, 0), (0, -1, 0), end.ppm)
    canvas.paste(end.texture, end.alpha, hom, cam.depth((0.0, 2.0, lay.end_z)))


def _disc_homography(lay: Layout) -> np.ndarray:
    """Texture → image homography of the disc plane, turned on its bracket."""
    yaw, pitch = lay.disc_turn
    axis_u = (float(np.cos(yaw)), 0.0, float(np.sin(yaw)))
    axis_v = (0.0, -float(np.cos(pitch)), float(np.sin(pitch)))
    r = lay.disc_radius
    x, y, z = lay.disc_pos
    origin = (x - r * axis_u[0], y + r * np.cos(pitch), z - r * axis_u[2] - r * axis_v[2])
    return lay.camera.plane_homography(origin, axis_u, axis_v, TEXTURE_PX / (2 * r))


def _paste_disc(canvas: Canvas, lay: Layout, light: Light, rng: Rng) -> FloatMap:
    """Disc on its bracket; returns its full (unoccluded) image mask."""
    import cv2

    look = choose_look(rng, snowy=light.snowy, night=lay.condition == "night")
    tex, alpha, refl, full = render_disc(rng, look)
    hom = _disc_homography(lay)
    depth = lay.camera.depth(lay.disc_pos)
    canvas.paste(tex, alpha, hom, depth)
    size = (lay.width, lay.height)
    mask = cv2.warpPerspective(full, hom, size, flags=cv2.INTER_LINEAR)
    if look.lit or (light.headlight > 0 and rng.random() < 0.5):
        glow = cv2.warpPerspective(refl * alpha, hom, size, flags=cv2.INTER_LINEAR)
        colour = np.asarray(look.reflector, np.float32) * np.float32(uniform(rng, (0.8, 2.2)))
        canvas.emission += glow[..., None] * colour
    return np.asarray(mask, np.float32)


def _occluding_pole(canvas: Canvas, lay: Layout, rng: Rng) -> None:
    """A near lineside pole crossing the disc's place (with or without a disc)."""
    u, v = lay.camera.project(np.asarray([lay.disc_pos]))[0]
    r_px = lay.camera.focal * lay.disc_radius / lay.camera.depth(lay.disc_pos)
    width = r_px * uniform(rng, RANGES.pole_width)
    cx = u + r_px * uniform(rng, RANGES.pole_offset) * (1.0 if rng.random() < 0.5 else -1.0)
    bottom = min(lay.height, v + r_px * uniform(rng, (3.0, 20.0)))
    grey = uniform(rng, (60.0, 170.0))
    xs = np.arange(lay.width, dtype=np.float32)
    across = np.clip(0.5 + (width / 2 - np.abs(xs - cx)), 0.0, 1.0)
    rows = (np.arange(lay.height) < bottom).astype(np.float32)
    mask = rows[:, None] * across[None, :]
    roundness = 1.0 - 0.5 * ((xs - cx) / max(width / 2, 1.0)) ** 2
    colour = np.clip(roundness, 0.4, 1.0)[None, :, None] * np.float32(grey)
    canvas.paint(mask.astype(np.float32), np.broadcast_to(colour, (*mask.shape, 3)).astype(
        np.float32), lay.camera.depth(lay.disc_pos) * 0.5)


def _world_negatives(canvas: Canvas, lay: Layout, rng: Rng) -> None:
    for kind in (lay.negative_kind, *lay.extras):
        if kind == "signal_light":
            neg.signal_light(canvas, lay.camera, rng, lay.end_z)
        elif kind == "red_barrier":
            neg.red_barrier(canvas, lay.camera, rng, lay.end_z)
        elif kind == "tail_lamp":
            neg.tail_lamps(canvas, lay.camera, lay.car, lay.end_z, rng)
    if lay.condition == "night":
        for _ in range(int(rng.integers(0, 5))):
            colour = hsv_to_bgr(uniform(rng, (10.0, 30.0)), uniform(rng, (0.0, 180.0)), 255.0)
            centre = (uniform(rng, (0.0, lay.width)), uniform(rng, (0.0, lay.height * 0.5)))
            neg.lamp_glow(canvas, centre, lay.height * uniform(rng, (0.002, 0.008)), colour,
                          uniform(rng, (0.6, 1.5)))


def paint(lay: Layout, rng: Rng) -> tuple[Uint8Image, FloatMap | None]:
    """The scene's final uint8 BGR image (after JPEG) and the disc's full mask."""
    light = choose_light(rng, lay.condition)
    canvas = Canvas(lay.width, lay.height)
    _background(canvas, lay, light, rng)
    _paste_car(canvas, lay, light, rng)
    mask = _paste_disc(canvas, lay, light, rng) if lay.disc else None
    if rng.random() < 0.5:
        catenary(canvas, lay.camera, rng, lay.end_z, front=True)
    if lay.pole_occlusion:
        _occluding_pole(canvas, lay, rng)
    _world_negatives(canvas, lay, rng)
    lit = precipitation(light_scene(canvas, light, rng), light, rng)
    lit, mask = tilt(lit, mask, rng)
    night = lay.condition == "night"
    image = sensor(optics(lit, rng, night=night), rng, night=night)
    return jpeg_round_trip(image, rng), mask
