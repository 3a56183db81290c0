"""Stage 2: features of one proposed disc (shape; colour inside vs rim vs ring; scale; scene).

Each proposal is segmented locally: ``evidence`` in a window of a few radii is split at
the midpoint between the centre's and the surround's level, and the component under
the centre (holes filled: the reflector) is the region. Its equivalent circle then
defines the zones where colour is compared: inside, the rim just outside the edge, and
a ring further out, also per sector (a disc stands out on every side; a stripe or a
letter stroke does not). No feature uses the position in the image: where a disc sits
depends on the camera, and position would teach the verifier one generator's layout.
Position relative to the car is used instead: a disc hangs just above the buffer beam,
dark below it, while lettering has body paint below and a signal its post.

No feature uses one paint's exact colour (the paper's band share was dropped: it
memorised one generator's red): colour enters as ratios (redness, chromaticity), as
the same after a grey-world white balance of the crop, and as contrasts with the
surroundings. ``in_clipped`` (pixels at the sensor's top) tells an emitting lamp from
lit paint.
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
    "in_redness_wb",
    "redness_wb_contrast",
    "in_clipped",
    "ring_clipped",
    "below_contrast",
    "above_below",
    *(f"{m}_r{i}" for m in ("redness", "value", "chroma") for i in range(6)),
    *(f"{m}_sector_std_r{i}" for m in ("evidence",) for i in range(6)),
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
    radial : edges of the rings around the region's circle (a rotation-invariant
        picture of reflector, paint, rim and surroundings); each ring is also split
        into ``sectors`` (a disc stands out on every side; a stripe or stroke crosses
        only some of them).
    inside_rings, rim_ring, outer_rings : which rings are the inside, the rim and the
        outer ring of the contrast features.
    sectors : sectors per ring.
    red_pixel : redness above which a pixel counts for the scene's red share.
    samples_per_radius : zones of large candidates are sampled on a grid this many
        points per radius (bounded cost at any size).
    below : the strip under (and, mirrored, over) a candidate, from and to this many
        radii from its centre, one diameter wide: where the buffer beam would be.
    """

    window: float = 2.6
    radial: tuple[float, ...] = (0.0, 0.3, 0.75, 1.0, 1.3, 1.7, 2.2)
    inside_rings: tuple[int, ...] = (0, 1)
    rim_ring: int = 3
    outer_rings: tuple[int, ...] = (4, 5)
    sectors: int = 8
    red_pixel: float = 0.35
    samples_per_radius: float = 6.0
    below: tuple[float, float] = (1.6, 4.0)


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
    x0, y0, x1, y1 = (
        max(0, cx - half),
        max(0, cy - half),
        min(w, cx + half + 1),
        min(h, cy + half + 1),
    )
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


def _cells(m: Maps, cx: float, cy: float, r: float, c: FeatureParams) -> NDArray[np.float64] | None:
    """Sums of (1, redness, chroma, value, evidence, band, redness²) per (ring, sector).

    Large candidates are sampled on a grid (``samples_per_radius``).
    """
    h, w = m.evidence.shape
    half = int(math.ceil(c.radial[-1] * r)) + 1
    x0, y0 = max(0, int(cx) - half), max(0, int(cy) - half)
    x1, y1 = min(w, int(cx) + half + 1), min(h, int(cy) + half + 1)
    step = max(1, int(r / c.samples_per_radius))
    yy, xx = np.mgrid[y0:y1:step, x0:x1:step].astype(np.float32)
    dx, dy = (xx - cx).ravel(), (yy - cy).ravel()
    ring = np.searchsorted(np.asarray(c.radial[1:]), np.hypot(dx, dy) / max(r, 0.5), side="right")
    sector = ((np.arctan2(dy, dx) + math.pi) * (c.sectors / (2 * math.pi))).astype(np.int64)
    n_r = len(c.radial) - 1
    keep = ring < n_r
    if not keep.any():
        return None
    cell = ring[keep] * c.sectors + np.minimum(sector[keep], c.sectors - 1)
    stack = m.stack[y0:y1:step, x0:x1:step].reshape(-1, m.stack.shape[2])[keep]
    n_c = n_r * c.sectors
    # bincount per channel: no BLAS call (its threads would fight over a loaded core).
    sums = [np.bincount(cell, weights=stack[:, k], minlength=n_c) for k in range(stack.shape[1])]
    return np.asarray(np.stack(sums, axis=1), np.float64).reshape(n_r, c.sectors, -1)


def _zone_stats(m: Maps, cx: float, cy: float, r: float, c: FeatureParams) -> list[float] | None:
    """Colour inside vs rim vs ring, per sector, and the radial profile."""
    cells = _cells(m, cx, cy, r, c)
    if cells is None:
        return None
    rings = cells.sum(axis=1)  # (ring, channel)

    def zone(*which: int) -> NDArray[np.float64] | None:
        total = rings[list(which)].sum(axis=0)
        return total[1:] / total[0] if total[0] > 0 else None

    inner, rim, outer = zone(*c.inside_rings), zone(c.rim_ring), zone(*c.outer_rings)
    centre = zone(0)
    if inner is None or rim is None or outer is None:
        return None
    red_i, chro_i, val_i, ev_i, _band_i, red2_i, wb_i, clip_i = inner
    sec = cells[list(c.outer_rings)].sum(axis=0)  # (sector, channel)
    seen = sec[:, 0] > 0
    per_sector = ev_i - sec[seen, 4] / sec[seen, 0]
    v_centre = centre[2] if centre is not None else val_i
    n = np.maximum(rings[:, :1], 1.0)
    profile = rings[:, 1:] / n  # (ring, channel)
    seen_cells = cells[:, :, 0] > 0
    sector_ev = np.where(seen_cells, cells[:, :, 4] / np.maximum(cells[:, :, 0], 1.0), 0.0)
    n_seen = np.maximum(seen_cells.sum(axis=1), 1)
    mean_ev = sector_ev.sum(axis=1) / n_seen
    dev = np.where(seen_cells, sector_ev - mean_ev[:, None], 0.0)
    spread = np.sqrt((dev**2).sum(axis=1) / n_seen).tolist()
    return [
        red_i,
        chro_i,
        val_i,
        math.sqrt(max(0.0, red2_i - red_i**2)),
        rim[2],
        rim[0],
        outer[0],
        outer[2],
        outer[1],
        ev_i - outer[3],
        val_i - outer[2],
        red_i - outer[0],
        chro_i - outer[1],
        ev_i - rim[3],
        float(per_sector.min()),
        float(per_sector.max()),
        v_centre / max(val_i, 1e-3),
        wb_i,
        wb_i - outer[6],
        clip_i,
        outer[7],
        *profile[:, 0].tolist(),
        *profile[:, 2].tolist(),
        *profile[:, 1].tolist(),
        *spread,
    ]


def _strip_mean(field: NDArray[np.float32], x0: float, x1: float, y0: float, y1: float) -> float:
    h, w = field.shape
    xa, xb = max(0, int(x0)), min(w, int(math.ceil(x1)))
    ya, yb = max(0, int(y0)), min(h, int(math.ceil(y1)))
    if xb <= xa or yb <= ya:
        return float("nan")
    return float(field[ya:yb, xa:xb].mean())


def _beam(
    m: Maps, cx: float, cy: float, r: float, c: FeatureParams, stats: list[float]
) -> tuple[float, float]:
    """(ring value - value below, value above - value below); 0 outside the frame."""
    lo, hi = c.below
    below = _strip_mean(m.value, cx - r, cx + r, cy + lo * r, cy + hi * r)
    above = _strip_mean(m.value, cx - r, cx + r, cy - hi * r, cy - lo * r)
    ring_value = stats[_RING_VALUE]
    b = ring_value if math.isnan(below) else below
    a = ring_value if math.isnan(above) else above
    return ring_value - b, a - b


_RING_VALUE = 7  # index of ring_value in _zone_stats' list
_BEAM_AT = 21  # where below_contrast goes in _zone_stats' list (after ring_clipped)


def _insert_beam(stats: list[float], beam: tuple[float, float]) -> list[float]:
    return [*stats[:_BEAM_AT], *beam, *stats[_BEAM_AT:]]


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
    stats = _insert_beam(stats, _beam(m, cx, cy, r, c, stats))
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
