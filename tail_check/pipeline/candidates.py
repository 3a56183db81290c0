"""Stage 1: candidate regions of disc colour, with their features (stage 2).

The paper's method finds the candidates: the search region at a fixed working scale,
Gaussian low-pass, per-channel band ``c_ref ± c_Δ`` (with the profile's exposure
gains). The band alone misses discs whose paint, light or reflector move them off
the camera's reference, so a chromaticity band (red clearly above green and blue,
at any brightness) is added; it only *proposes* regions, the verifier decides.
Two passes: with dark seams cut (a disc's dark rim next to a red body) and without
(a disc whose reflector or rim the seam test would split). Holes (the reflector) are
filled before the shape is measured.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from ..colour import band_mask
from ..detect import WORK_SIDE, _not_in_valley, region_box, veil_level
from ..profile import CameraProfile
from ..regions import DiscCandidate
from ..shape import RegionShape, measure_region

__all__ = ["FEATURE_NAMES", "Candidate", "CandidateParams", "find_candidates"]

BBox = tuple[int, int, int, int]


@dataclass(frozen=True)
class CandidateParams:
    """Parameters of the candidate stage.

    Attributes
    ----------
    red_margin : float
        Minimum ``R - max(G, B)`` of the low-passed colour, 0..255, for the chromaticity band.
    red_ratio : float
        Minimum ``R / max(G, B)`` for the chromaticity band.
    min_red : float
        Minimum ``R`` (0..255): darker pixels carry no colour information.
    diameter_range : (float, float)
        Equivalent-circle diameter kept, as a fraction of the working side.
    max_candidates : int
        Largest regions kept per pass (the rest are clutter of a red body).
    ring_width : float
        Width of the ring outside a region used for contrast, in region radii.
    hand_candidates : int
        Best candidates of the hand-tuned detector also verified.
    """

    red_margin: float = 14.0
    red_ratio: float = 1.35
    min_red: float = 22.0
    diameter_range: tuple[float, float] = (0.012, 0.30)
    max_candidates: int = 12
    ring_width: float = 0.6
    hand_candidates: int = 3


CANDIDATE_PARAMS = CandidateParams()
MIN_SIGMA_PX = 0.3
"""Below this σ (working pixels) the low-pass is skipped, as in the hand-tuned detector."""
AREA_SLACK = 1.6
"""Components up to this times the largest disc area are measured: holes filled later
(the reflector) can make a region's own pixel count smaller than its disc's."""

FEATURE_NAMES: tuple[str, ...] = (
    "diameter",
    "fill",
    "ellipse_iou",
    "solidity",
    "aspect",
    "hole_fraction",
    "ellipse_residual",
    "holes",
    "large_holes",
    "circularity",
    "in_chroma_r",
    "in_chroma_g",
    "in_value",
    "in_redness",
    "ring_redness",
    "ring_value",
    "redness_contrast",
    "value_contrast",
    "centre_brightness",
    "in_band_share",
    "x_rel",
    "y_rel",
    "touches_edge",
    "seam_cut",
    "region_red_share",
    "region_value",
    "hand_score",
    "from_hand",
)
"""Names of the feature vector, in order (shape; colour inside vs ring; position; scene)."""


@dataclass(frozen=True)
class Candidate:
    """One candidate region and its features.

    Attributes
    ----------
    bbox : (x, y, w, h) in pixels of the original image.
    diameter : equivalent-circle diameter, fraction of ``sqrt(W*H)``.
    shape : the shape measures.
    mean_rgb : mean low-passed colour inside, RGB 0..255.
    features : vector in the order of :data:`FEATURE_NAMES`.
    """

    bbox: BBox
    diameter: float
    shape: RegionShape
    mean_rgb: tuple[float, float, float]
    features: NDArray[np.float64]


@dataclass(frozen=True)
class _Scene:
    smooth: NDArray[np.float32]
    band: NDArray[np.bool_]
    origin: tuple[int, int]
    scale: float
    image_size: tuple[int, int]
    red_share: float
    value: float


def _chroma_mask(smooth: NDArray[np.float32], c: CandidateParams) -> NDArray[np.bool_]:
    b, g, r = smooth[..., 0], smooth[..., 1], smooth[..., 2]
    other = np.maximum(g, b)
    return np.asarray((r - other >= c.red_margin) & (r >= c.red_ratio * other) & (r >= c.min_red))


def _fill_holes(component: NDArray[np.uint8]) -> NDArray[np.uint8]:
    padded = np.pad(component, 1)
    flood = padded.copy()
    cv2.floodFill(flood, None, (0, 0), 1)
    holes = flood == 0
    return np.asarray(padded[1:-1, 1:-1] | holes[1:-1, 1:-1], dtype=np.uint8)


def _colour_features(
    scene: _Scene, filled: NDArray[np.uint8], box: BBox, radius: float, c: CandidateParams
) -> list[float]:
    x, y, w, h = box
    pad = max(2, int(math.ceil(c.ring_width * radius)))
    hh, ww = scene.band.shape
    x0, y0, x1, y1 = max(0, x - pad), max(0, y - pad), min(ww, x + w + pad), min(hh, y + h + pad)
    local = np.zeros((y1 - y0, x1 - x0), np.uint8)
    local[y - y0 : y - y0 + h, x - x0 : x - x0 + w] = filled
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * pad + 1, 2 * pad + 1))
    ring = (cv2.dilate(local, kernel) > 0) & (local == 0)
    inside = local > 0
    patch = scene.smooth[y0:y1, x0:x1]
    band = scene.band[y0:y1, x0:x1]

    def stats(sel: NDArray[np.bool_]) -> tuple[float, float, float, float]:
        if not sel.any():
            return 0.0, 0.0, 0.0, 0.0
        px = patch[sel]
        b, g, r = px[:, 0].mean(), px[:, 1].mean(), px[:, 2].mean()
        total = max(1.0, float(r + g + b))
        redness = float((px[:, 2] - np.maximum(px[:, 0], px[:, 1])).mean()) / 255.0
        return float(r) / total, float(g) / total, float(px.max(axis=1).mean()) / 255.0, redness

    cr, cg, v_in, red_in = stats(inside)
    _, _, v_ring, red_ring = stats(ring)
    core = cv2.erode(
        local,
        cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3)),
        iterations=max(1, int(radius * 0.5)),
    )
    v_core = stats(core > 0)[2] if np.any(core) else v_in
    band_share = float(band[inside].mean()) if inside.any() else 0.0
    return [
        cr,
        cg,
        v_in,
        red_in,
        red_ring,
        v_ring,
        red_in - red_ring,
        v_in - v_ring,
        v_core / max(v_in, 1e-3),
        band_share,
    ]


def _features(
    scene: _Scene,
    filled: NDArray[np.uint8],
    box: BBox,
    shape: RegionShape,
    flags: tuple[float, float, float],
    c: CandidateParams,
) -> tuple[BBox, float, tuple[float, float, float], NDArray[np.float64]]:
    """Box in image pixels, diameter, mean colour and the feature vector of a region.

    ``flags`` are (seam cut, hand-tuned disc score, from the hand-tuned detector).
    """
    x, y, w, h = box
    area = max(1.0, float(filled.sum()))
    radius = math.sqrt(area / math.pi)
    contours, _ = cv2.findContours(filled, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    perimeter = max(1.0, sum(cv2.arcLength(cnt, True) for cnt in contours))
    inside = scene.smooth[y : y + h, x : x + w][filled > 0]
    mean_bgr = inside.mean(axis=0) if inside.size else np.zeros(3)
    hh, ww = scene.band.shape
    full_w, full_h = scene.image_size
    cx = (scene.origin[0] + (x + w / 2) / scene.scale) / full_w
    cy = (scene.origin[1] + (y + h / 2) / scene.scale) / full_h
    edge = float(x == 0 or y == 0 or x + w >= ww or y + h >= hh)
    diameter = 2.0 * radius / WORK_SIDE
    feats = [
        diameter,
        shape.fill,
        shape.ellipse_iou,
        shape.solidity,
        shape.aspect,
        shape.hole_fraction,
        shape.ellipse_residual,
        float(shape.holes),
        float(shape.large_holes),
        min(1.5, 4.0 * math.pi * area / perimeter**2),
        *_colour_features(scene, filled, box, radius, c),
        cx,
        cy,
        edge,
        flags[0],
        scene.red_share,
        scene.value,
        flags[1],
        flags[2],
    ]
    bbox = (
        scene.origin[0] + int(round(x / scene.scale)),
        scene.origin[1] + int(round(y / scene.scale)),
        max(1, int(round(w / scene.scale))),
        max(1, int(round(h / scene.scale))),
    )
    rgb = (float(mean_bgr[2]), float(mean_bgr[1]), float(mean_bgr[0]))
    return bbox, diameter, rgb, np.asarray(feats, np.float64)


def _candidate(
    scene: _Scene,
    labels: NDArray[np.int32],
    k: int,
    stat: NDArray[np.int32],
    cut: bool,
    c: CandidateParams,
) -> Candidate | None:
    x, y, w, h = (int(v) for v in stat[:4])
    comp = np.asarray(labels[y : y + h, x : x + w] == k, dtype=np.uint8)
    shape = measure_region(comp.astype(bool))
    if shape is None:
        return None
    filled = _fill_holes(comp)
    bbox, diameter, rgb, feats = _features(scene, filled, (x, y, w, h), shape, (cut, 0, 0), c)
    return Candidate(bbox, diameter, shape, rgb, feats)


def _from_hand(scene: _Scene, hand: DiscCandidate, c: CandidateParams) -> Candidate | None:
    """A hand-tuned detector's candidate as an elliptic region of its box."""
    bx, by, bw, bh = hand.bbox
    x = int(round((bx - scene.origin[0]) * scene.scale))
    y = int(round((by - scene.origin[1]) * scene.scale))
    w, h = max(2, int(round(bw * scene.scale))), max(2, int(round(bh * scene.scale)))
    hh, ww = scene.band.shape
    x, y = min(max(0, x), ww - 1), min(max(0, y), hh - 1)
    w, h = min(w, ww - x), min(h, hh - y)
    if w < 2 or h < 2:
        return None
    filled = np.zeros((h, w), np.uint8)
    cv2.ellipse(filled, (w // 2, h // 2), (max(1, w // 2), max(1, h // 2)), 0, 0, 360, 1, -1)
    flags = (0.0, hand.score, 1.0)
    bbox, _, rgb, feats = _features(scene, filled, (x, y, w, h), hand.shape, flags, c)
    return Candidate(hand.bbox, hand.diameter, hand.shape, rgb, feats)


def _prepare(image: NDArray[np.uint8], p: CameraProfile) -> tuple[_Scene, NDArray[np.uint8]]:
    height, width = image.shape[:2]
    box = region_box(p, width, height)
    scale = WORK_SIDE / math.sqrt(width * height)
    x, y, w, h = box
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
    crop = image[y : y + h, x : x + w]
    work = np.asarray(cv2.resize(crop, size, interpolation=interp), dtype=np.uint8)
    sigma_px = p.sigma * WORK_SIDE
    smooth8 = work
    if sigma_px >= MIN_SIGMA_PX:
        smooth8 = np.asarray(cv2.GaussianBlur(work, (0, 0), sigma_px), dtype=np.uint8)
    veil = veil_level(smooth8)
    if veil > 0:
        smooth8 = np.asarray(cv2.subtract(smooth8, np.full(3, veil, np.float64)), dtype=np.uint8)
    band = band_mask(smooth8, p.reference_rgb, p.c_delta, gain_range=p.gain_range)
    smooth = smooth8.astype(np.float32)
    scene = _Scene(
        smooth,
        band,
        (x, y),
        scale,
        (width, height),
        float(band.mean()),
        float(smooth.max(axis=2).mean()) / 255.0,
    )
    return scene, np.asarray(_not_in_valley(work, sigma_px), dtype=np.uint8)


def find_candidates(
    image: NDArray[np.uint8],
    p: CameraProfile,
    *,
    hand: tuple[DiscCandidate, ...] = (),
    params: CandidateParams = CANDIDATE_PARAMS,
) -> tuple[list[Candidate], NDArray[np.bool_]]:
    """Candidate regions of one snapshot and the paper's band mask (working scale).

    Parameters
    ----------
    image : ndarray, shape (H, W, 3), uint8, BGR
    p : the camera profile (search region, ``c_ref``, ``c_Δ``, σ, gains)
    hand : the hand-tuned detector's candidates; the best few are verified too
        (they come first in the result, best first)

    Returns
    -------
    candidates : list of Candidate (the hand-tuned ones first)
    band : ndarray (h, w) bool, the paper's ``c_ref ± c_Δ`` band on the working crop
    """
    scene, valley_free = _prepare(image, p)
    proposal = (scene.band | _chroma_mask(scene.smooth, params)).astype(np.uint8)
    dmin, dmax = params.diameter_range
    amin, amax = math.pi / 4 * (dmin * WORK_SIDE) ** 2, math.pi / 4 * (dmax * WORK_SIDE) ** 2
    found: list[Candidate] = []
    for prior in hand[: params.hand_candidates]:
        cand = _from_hand(scene, prior, params)
        if cand is not None:
            found.append(cand)
    for cut, mask in ((True, proposal & valley_free), (False, proposal)):
        _, found_labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
        labels = np.asarray(found_labels, dtype=np.int32)
        areas = stats[1:, cv2.CC_STAT_AREA]
        keep = [int(i) + 1 for i in np.argsort(-areas) if amin <= areas[i] <= amax * AREA_SLACK]
        for k in keep[: params.max_candidates]:
            cand = _candidate(scene, labels, k, stats[k], cut, params)
            if cand is not None and dmin <= cand.diameter <= dmax:
                found.append(cand)
    return found, scene.band
