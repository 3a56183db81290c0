"""Stage 2: features of one proposed disc (shape; colour inside vs rim vs ring; scale; scene).

Each proposal is segmented locally: ``evidence`` in a window of a few radii is split at
the midpoint between the centre's and the surround's level, and the component under
the centre (holes filled: the reflector) is the region. Its equivalent circle then
defines the zones where colour is compared: inside, the rim just outside the edge, and
a ring further out, also per sector (a disc stands out on every side; a stripe or a
letter stroke does not). No feature uses the position in the image: where a disc sits
depends on the camera, and position would teach the verifier one generator's layout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from .proposals import LIT_SOURCE, Maps, Proposal

__all__ = ["FEATURE_NAMES", "Candidate", "FeatureParams", "describe"]

BBox = tuple[int, int, int, int]

FEATURE_NAMES: tuple[str, ...] = (
    "diameter",
    "radius_ratio",
    "fill",
    "solidity",
    "circularity",
    "aspect",
    "hole_fraction",
    "leaks",
    "in_redness",
    "in_chroma",
    "in_value",
    "in_redness_std",
    "rim_value",
    "rim_redness",
    "ring_redness",
    "ring_value",
    "ring_chroma",
    "evidence_contrast",
    "value_contrast",
    "redness_contrast",
    "chroma_contrast",
    "rim_contrast",
    "sector_min_contrast",
    "sector_max_contrast",
    "centre_brightness",
    "in_band_share",
    "response",
    "source",
    "scene_bright",
    "scene_red_share",
)
"""Names of the feature vector, in order."""


@dataclass(frozen=True)
class FeatureParams:
    """Zones and segmentation of the feature stage (in radii of the region's circle).

    Attributes
    ----------
    window : half-side of the segmentation window, in proposal radii.
    inner, rim, ring : (from, to) radii of the inside, rim and outer-ring zones.
    sectors : sectors of the outer ring for the all-sides contrast.
    centre : radius of the centre zone (the reflector), in radii.
    red_pixel : redness above which a pixel counts for the scene's red share.
    samples_per_radius : zones of large candidates are sampled on a grid this many
        points per radius (bounded cost at any size).
    """

    window: float = 2.6
    inner: tuple[float, float] = (0.0, 0.75)
    rim: tuple[float, float] = (0.9, 1.25)
    ring: tuple[float, float] = (1.4, 2.2)
    sectors: int = 8
    centre: float = 0.3
    red_pixel: float = 0.35
    samples_per_radius: float = 6.0


FEATURE_PARAMS = FeatureParams()


@dataclass(frozen=True)
class Candidate:
    """A verified-to-be candidate: its box in image pixels, circle and features."""

    bbox: BBox
    diameter: float
    """Equivalent-circle diameter as a fraction of the working side."""
    circle: tuple[float, float, float]
    """(cx, cy, r) in working pixels."""
    features: NDArray[np.float64]


def _segment(
    m: Maps, pr: Proposal, c: FeatureParams
) -> tuple[NDArray[np.uint8], float, int, int] | None:
    """The region under the proposal's centre in its window, holes filled, and its origin."""
    h, w = m.evidence.shape
    half = max(3, int(math.ceil(c.window * pr.r)))
    cx, cy = int(round(pr.cx)), int(round(pr.cy))
    x0, y0, x1, y1 = max(0, cx - half), max(0, cy - half), min(w, cx + half + 1), min(h, cy + half + 1)
    field = m.value if pr.source == LIT_SOURCE else m.evidence
    win = field[y0:y1, x0:x1]
    yy, xx = np.ogrid[y0:y1, x0:x1]
    d2 = (xx - pr.cx) ** 2 + (yy - pr.cy) ** 2
    inner = win[d2 <= (0.6 * pr.r) ** 2]
    outer = win[d2 >= (1.5 * pr.r) ** 2]
    if inner.size == 0 or outer.size == 0:
        return None
    level = 0.5 * (float(inner.mean()) + float(outer.mean()))
    mask = (win > level).astype(np.uint8)
    n, labels = cv2.connectedComponents(mask, connectivity=8)
    sel = labels[d2 <= (0.6 * pr.r) ** 2]
    sel = sel[sel > 0]
    if sel.size == 0:
        return None
    k = int(np.bincount(sel).argmax())
    comp = (labels == k).astype(np.uint8)
    padded = np.pad(comp, 1)
    flood = padded.copy()
    cv2.floodFill(flood, None, (0, 0), 1)
    filled = np.asarray(padded[1:-1, 1:-1] | (flood[1:-1, 1:-1] == 0), np.uint8)
    return filled, float(comp.sum()), x0, y0


def _shape(filled: NDArray[np.uint8], comp_area: float) -> list[float] | None:
    contours, _ = cv2.findContours(filled, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return None
    outline = max(contours, key=cv2.contourArea)
    area = float(filled.sum())
    if area < 4:
        return None
    _, _, bw, bh = cv2.boundingRect(outline)
    hull = max(1.0, float(cv2.contourArea(cv2.convexHull(outline))))
    perim = max(1.0, float(cv2.arcLength(outline, True)))
    hh, ww = filled.shape
    leaks = float(bw >= ww - 1 or bh >= hh - 1)
    return [
        area / max(1.0, float(bw * bh)),
        min(1.5, area / hull),
        min(1.5, 4 * math.pi * area / perim**2),
        max(bw, bh) / max(1.0, float(min(bw, bh))),
        1.0 - comp_area / area,
        leaks,
    ]


def _zone_stats(m: Maps, cx: float, cy: float, r: float, c: FeatureParams) -> list[float] | None:
    """Mean maps per zone: 0 centre, 1 rest of inside, 2 rim, 3.. outer-ring sectors."""
    h, w = m.evidence.shape
    half = int(math.ceil(c.ring[1] * r)) + 1
    x0, y0 = max(0, int(cx) - half), max(0, int(cy) - half)
    x1, y1 = min(w, int(cx) + half + 1), min(h, int(cy) + half + 1)
    step = max(1, int(r / c.samples_per_radius))
    yy, xx = np.mgrid[y0:y1:step, x0:x1:step].astype(np.float32)
    dx, dy = xx - cx, yy - cy
    dist = np.hypot(dx, dy) / max(r, 0.5)
    sector = ((np.arctan2(dy, dx) + math.pi) * (c.sectors / (2 * math.pi))).astype(np.int64)
    zone = np.full(dist.shape, -1, np.int64)
    zone[dist < c.inner[1]] = 1
    zone[dist < c.centre] = 0
    zone[(dist >= c.rim[0]) & (dist < c.rim[1])] = 2
    ring = (dist >= c.ring[0]) & (dist < c.ring[1])
    zone[ring] = 3 + np.minimum(sector[ring], c.sectors - 1)
    keep = zone >= 0
    idx = zone[keep]
    n_z = 3 + c.sectors
    sl = (slice(y0, y1, step), slice(x0, x1, step))
    count = np.bincount(idx, minlength=n_z).astype(np.float64)
    if count[0] + count[1] == 0 or count[2] == 0 or count[3:].sum() == 0:
        return None

    def sums(a: NDArray[np.float32] | NDArray[np.bool_]) -> NDArray[np.float64]:
        return np.bincount(idx, weights=a[sl][keep].astype(np.float64), minlength=n_z)

    red, chro, val, ev, band = (sums(a) for a in (m.redness, m.chroma, m.value, m.evidence, m.band))
    red2 = np.bincount(idx, weights=m.redness[sl][keep].astype(np.float64) ** 2, minlength=n_z)
    n_in, n_ring = count[0] + count[1], count[3:].sum()

    def inside(s: NDArray[np.float64]) -> float:
        return float((s[0] + s[1]) / n_in)

    def outer(s: NDArray[np.float64]) -> float:
        return float(s[3:].sum() / n_ring)

    rim = count[2]
    sec = count[3:] > 0
    per_sector = inside(ev) - ev[3:][sec] / count[3:][sec]
    v_in = inside(val)
    v_centre = float(val[0] / count[0]) if count[0] else v_in
    r_in = inside(red)
    return [
        r_in,
        inside(chro),
        v_in,
        math.sqrt(max(0.0, inside(red2) - r_in**2)),
        float(val[2] / rim),
        float(red[2] / rim),
        outer(red),
        outer(val),
        outer(chro),
        inside(ev) - outer(ev),
        v_in - outer(val),
        r_in - outer(red),
        inside(chro) - outer(chro),
        inside(ev) - float(ev[2] / rim),
        float(per_sector.min()),
        float(per_sector.max()),
        v_centre / max(v_in, 1e-3),
        inside(band),
    ]


def describe(
    m: Maps, pr: Proposal, scene: tuple[float, float], c: FeatureParams = FEATURE_PARAMS
) -> Candidate | None:
    """The candidate of one proposal (None when it does not segment into a region).

    ``scene`` is (bright level, red share) of the crop.
    """
    seg = _segment(m, pr, c)
    if seg is None:
        return None
    filled, comp_area, x0, y0 = seg
    shape = _shape(filled, comp_area)
    if shape is None:
        return None
    ys, xs = np.nonzero(filled)
    cx, cy = float(xs.mean()) + x0, float(ys.mean()) + y0
    r = math.sqrt(float(filled.sum()) / math.pi)
    stats = _zone_stats(m, cx, cy, r, c)
    if stats is None:
        return None
    feats = [2 * r / m.work_side, r / pr.r, *shape, *stats]
    feats += [pr.response, float(pr.source), *scene]
    ox, oy = m.origin
    bbox = (
        ox + int(round((cx - r) / m.scale)),
        oy + int(round((cy - r) / m.scale)),
        max(1, int(round(2 * r / m.scale))),
        max(1, int(round(2 * r / m.scale))),
    )
    return Candidate(bbox, feats[0], (cx, cy, r), np.asarray(feats, np.float64))
