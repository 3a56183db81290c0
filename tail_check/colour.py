"""Colour extraction of the paper: low-pass pre-filters and the ``c_ref ± c_Δ`` band.

The band is applied per RGB component, ``|x_c - k·c_ref,c| <= k·c_Δ·mean(c_ref)``,
for some exposure gain ``k`` in a configured range. ``k = 1`` is exactly the paper's
rule; letting ``k`` vary keeps one band valid from noon to night without moving the
band's shape (the ratio between the channels is what separates the disc from
red-brown or rust cars).
"""

from __future__ import annotations

import functools
from typing import Any, Literal

import cv2
import numpy as np
from numpy.typing import NDArray

from .shape import CutDisc, ramp

__all__ = [
    "FILTER_KINDS",
    "FilterKind",
    "band_mask",
    "filter_kernel",
    "low_pass",
    "occluder_continues",
    "surround_share",
]

FilterKind = Literal["box", "disk", "gaussian"]
FILTER_KINDS: tuple[FilterKind, ...] = ("box", "disk", "gaussian")
TABLE_MIN_PIXELS = 20_000
"""From this many pixels on, a uint8 image's band is found by lookup tables (the same mask;
building the tables costs about as much as the float path on a 120x120 window)."""


def filter_kernel(
    kind: FilterKind, size: int, *, sigma: float | None = None
) -> NDArray[np.float32]:
    """FIR low-pass kernel normalised to sum 1.

    Parameters
    ----------
    kind : {"box", "disk", "gaussian"}
        ``box``: ``h = 1/(M·N)``; ``disk``: average over the inscribed circle;
        ``gaussian``: ``exp(-(i²+j²)/(2σ²))`` normalised.
    size : int
        Kernel side N in pixels (made odd, at least 1).
    sigma : float, optional
        Gaussian σ in pixels (default ``size / 4``).

    Returns
    -------
    ndarray, shape (N, N), float32
    """
    if size < 1:
        raise ValueError(f"filter size must be >= 1 pixel, got {size}")
    n = int(size) | 1
    r = n // 2
    jj, ii = np.mgrid[-r : r + 1, -r : r + 1].astype(np.float64)
    if kind == "box":
        h = np.ones((n, n))
    elif kind == "disk":
        h = (ii**2 + jj**2 <= (r + 0.5) ** 2).astype(np.float64)
    elif kind == "gaussian":
        s = float(sigma) if sigma is not None else n / 4.0
        if s <= 0:
            raise ValueError(f"gaussian sigma must be > 0, got {s}")
        h = np.exp(-(ii**2 + jj**2) / (2.0 * s * s))
    else:
        raise ValueError(f"unknown filter kind {kind!r}; use one of {FILTER_KINDS}")
    return np.asarray(h / h.sum(), dtype=np.float32)


def low_pass(
    image: NDArray[np.generic], kind: FilterKind, size: int, *, sigma: float | None = None
) -> NDArray[np.float32]:
    """Filter an image with one of the paper's low-pass FIR filters.

    Parameters
    ----------
    image : ndarray, shape (H, W) or (H, W, C)
        Any numeric image; not modified.
    kind, size, sigma
        See :func:`filter_kernel`.

    Returns
    -------
    ndarray, same shape, float32
    """
    src = np.asarray(image, dtype=np.float32)
    n = int(size) | 1
    out: NDArray[np.generic]
    if size <= 1:
        out = src.copy()
    elif kind == "gaussian":
        s = float(sigma) if sigma is not None else n / 4.0
        out = cv2.GaussianBlur(src, (n, n), s, borderType=cv2.BORDER_REFLECT)
    elif kind == "box":
        out = cv2.blur(src, (n, n), borderType=cv2.BORDER_REFLECT)
    else:
        kernel = filter_kernel(kind, size, sigma=sigma)
        out = cv2.filter2D(src, -1, kernel, borderType=cv2.BORDER_REFLECT)
    return np.asarray(out, dtype=np.float32)


def band_mask(
    image_bgr: NDArray[np.generic],
    reference_rgb: tuple[float, float, float],
    c_delta: float,
    *,
    gain_range: tuple[float, float] = (1.0, 1.0),
) -> NDArray[np.bool_]:
    """Pixels inside the band ``k·(c_ref ± c_Δ·mean(c_ref))`` on every channel, some ``k``.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3)
        BGR image, values 0..255 (any numeric dtype); not modified.
    reference_rgb : tuple of 3 float
        ``c_ref`` in RGB order, 0..255.
    c_delta : float
        Band half-width as a fraction of ``mean(c_ref)`` (0.25 = 25 %).
    gain_range : tuple of 2 float
        Allowed exposure gains ``(k_min, k_max)``; ``(1, 1)`` is the paper's fixed band.

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    img = np.asarray(image_bgr)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"expected a BGR image of shape (H, W, 3), got {img.shape}")
    if c_delta <= 0:
        raise ValueError(f"c_delta must be > 0, got {c_delta}")
    k_min, k_max = float(gain_range[0]), float(gain_range[1])
    if not 0 < k_min <= k_max:
        raise ValueError(f"gain_range must satisfy 0 < k_min <= k_max, got {gain_range}")
    ref_bgr = np.array(reference_rgb[::-1], dtype=np.float32)
    half = np.float32(c_delta * float(np.mean(ref_bgr)))
    if img.dtype == np.uint8 and img.shape[0] * img.shape[1] >= TABLE_MIN_PIXELS:
        return _band_mask_u8(img, ref_bgr, half, k_min, k_max)
    x = img.astype(np.float32, copy=False)
    # Feasible gains per channel: x/(r+Δ) <= k <= x/(r-Δ); the band holds if the
    # intersection over the three channels meets [k_min, k_max].
    k_lo = np.full(x.shape[:2], k_min, dtype=np.float32)
    k_hi = np.full(x.shape[:2], k_max, dtype=np.float32)
    for c in range(3):
        channel = x[..., c]
        np.maximum(k_lo, channel * (1.0 / (ref_bgr[c] + half)), out=k_lo)
        if ref_bgr[c] > half:
            np.minimum(k_hi, channel * (1.0 / (ref_bgr[c] - half)), out=k_hi)
    return np.asarray(k_lo <= k_hi)


def _gain_tables(
    ref_bgr: NDArray[np.float32], half: np.float32
) -> tuple[list[NDArray[np.float32]], list[NDArray[np.float32] | None]]:
    """Per channel and level 0..255, the gain bounds ``x/(r+Δ)`` and ``x/(r-Δ)`` (None
    where ``r <= Δ``: no upper bound), computed exactly as the float path does per pixel."""
    levels = np.arange(256, dtype=np.float32)
    lows = [levels * (1.0 / (ref_bgr[c] + half)) for c in range(3)]
    highs = [levels * (1.0 / (ref_bgr[c] - half)) if ref_bgr[c] > half else None for c in range(3)]
    return lows, highs


RankTables = tuple[
    tuple[NDArray[np.unsignedinteger[Any]], ...], tuple[NDArray[np.unsignedinteger[Any]], ...]
]


@functools.lru_cache(maxsize=8)
def _rank_tables(
    ref_bgr: tuple[float, float, float], half: float, k_min: float, k_max: float
) -> RankTables:
    """Per channel, the lower and upper gain bound of every level as a small integer rank.

    The band holds iff ``max_c L_c(x_c) <= min_d H_d(x_d)`` with ``L_c = max(k_min, lo_c)``
    and ``H_d = min(k_max, hi_d)`` (the float path's ``k_lo <= k_hi``). Only the order of
    the L values against the H values matters, so each bound is replaced by its position
    among the distinct "how many L values lie at or below" counts of the H values: the
    same comparisons, in uint8 when there are at most 256 positions (the camera bands
    have about 190). A camera's band is the same for every snapshot: cached.
    """
    ref = np.array(ref_bgr, dtype=np.float32)
    lows, highs = _gain_tables(ref, np.float32(half))
    lo_limit, hi_limit = np.float32(k_min), np.float32(k_max)
    lo = [np.maximum(lo_limit, t) for t in lows]
    hi = [np.full(256, hi_limit) if t is None else np.minimum(hi_limit, t) for t in highs]
    l_sorted = np.unique(np.concatenate(lo))
    at_or_below = [np.searchsorted(l_sorted, t, side="right") for t in hi]
    positions = np.unique(np.concatenate(at_or_below))
    hi_rank = [np.searchsorted(positions, t) for t in at_or_below]
    # L_c <= H_d iff (index of L_c among the L values) + 1 <= (L values at or below H_d).
    lo_rank = [np.searchsorted(positions, np.searchsorted(l_sorted, t) + 1) for t in lo]
    dtype = np.uint8 if len(positions) <= 255 else np.uint16
    return tuple(t.astype(dtype) for t in lo_rank), tuple(t.astype(dtype) for t in hi_rank)


def _band_mask_u8(
    img: NDArray[np.uint8],
    ref_bgr: NDArray[np.float32],
    half: np.float32,
    k_min: float,
    k_max: float,
) -> NDArray[np.bool_]:
    """:func:`band_mask` of a uint8 image by lookup tables, with the same result: six
    table look-ups, four min/max and one compare of small integers per pixel instead of
    float images (see :func:`_rank_tables`)."""
    ref_key = (float(ref_bgr[0]), float(ref_bgr[1]), float(ref_bgr[2]))
    lo_rank, hi_rank = _rank_tables(ref_key, float(half), k_min, k_max)
    channels = cv2.split(np.ascontiguousarray(img))
    lo = [cv2.LUT(channels[c], lo_rank[c]) for c in range(3)]
    hi = [cv2.LUT(channels[c], hi_rank[c]) for c in range(3)]
    k_lo = cv2.max(cv2.max(lo[0], lo[1]), lo[2])
    k_hi = cv2.min(cv2.min(hi[0], hi[1]), hi[2])
    ok = cv2.compare(k_lo, k_hi, cv2.CMP_LE)
    return np.asarray(cv2.min(ok, 1), dtype=np.uint8).view(bool)


def _edge_colour(
    image: NDArray[np.uint8], cut: CutDisc, at: tuple[int, int], ts: NDArray[np.float64]
) -> NDArray[np.float64] | None:
    """Median colour just on the hidden side of the edge line at positions ``ts``."""
    (vx, vy), (nx, ny) = cut.edge_direction, cut.hidden_normal
    depth = np.linspace(3.0, 5.0, 3)  # past the low-pass bleed of the disc colour
    xs = at[0] + cut.edge_point[0] + ts[:, None] * vx + depth[None, :] * nx
    ys = at[1] + cut.edge_point[1] + ts[:, None] * vy + depth[None, :] * ny
    xi, yi = np.round(xs).astype(int).ravel(), np.round(ys).astype(int).ravel()
    inside = (xi >= 0) & (yi >= 0) & (xi < image.shape[1]) & (yi < image.shape[0])
    if np.count_nonzero(inside) < 0.8 * inside.size:
        return None
    return np.asarray(np.median(image[yi[inside], xi[inside]], axis=0), dtype=np.float64)


def occluder_continues(image: NDArray[np.uint8], cut: CutDisc, at: tuple[int, int]) -> float:
    """0..1: whatever hides the cut-off side goes on past the disc along the edge.

    A pole or post in front of the disc is longer than the disc: beyond both ends of
    the cut its colour continues along the same straight edge. A straight edge inside
    an object (a glyph on a red plate, a rib) does not.

    Parameters
    ----------
    image : ndarray (h, w, 3) uint8
        The low-passed image the region was found in.
    cut : CutDisc
        The region's cut-disc fit.
    at : (x, y)
        The region box's top-left corner in ``image``.
    """
    t0, t1 = cut.span
    r = 0.5 * cut.diameter
    behind = _edge_colour(image, cut, at, np.linspace(t0, t1, 7)[1:-1])
    if behind is None:
        return 0.0
    worst, seen = 1.0, 0
    for ts in (
        np.linspace(t1 + 0.3 * r, t1 + 0.9 * r, 4),
        np.linspace(t0 - 0.9 * r, t0 - 0.3 * r, 4),
    ):
        beyond = _edge_colour(image, cut, at, ts)
        if beyond is None:
            continue
        seen += 1
        diff = float(np.max(np.abs(beyond - behind)))
        tol = max(12.0, 0.2 * float(np.max(behind)))
        worst = min(worst, ramp(diff, -1.0, -1.0, tol, 2.0 * tol))
    return worst if seen else 0.0


def surround_share(
    band: NDArray[np.bool_],
    red: NDArray[np.uint8],
    box: tuple[int, int, int, int],
    level: float,
    *,
    extra: tuple[NDArray[np.bool_], tuple[int, int]] | None = None,
) -> float:
    """Share of an elliptic ring (1.25-1.7 radii) around a region that is the same
    surface: inside the colour band at a similar level of the red channel.

    A disc is an object of its own; a disc-shaped piece cut out of a red car body by
    ribs, stencils or shadows is surrounded by more of the same paint. ``extra`` is a
    second band of a window, ``(mask, (x, y))``, counted as if or-ed into ``band`` (only
    the ring's part of it is combined, not a whole image per region).
    """
    x, y, w, h = box
    cx, cy, ax, ay = x + w / 2.0, y + h / 2.0, max(w / 2.0, 0.5), max(h / 2.0, 0.5)
    x0, x1 = max(0, int(cx - 1.7 * ax) - 1), min(band.shape[1], int(cx + 1.7 * ax) + 2)
    y0, y1 = max(0, int(cy - 1.7 * ay) - 1), min(band.shape[0], int(cy + 1.7 * ay) + 2)
    yy, xx = np.ogrid[y0:y1, x0:x1]  # broadcast: the same values as a full grid
    rho = ((xx + 0.5 - cx) / ax) ** 2 + ((yy + 0.5 - cy) / ay) ** 2
    ring = (rho >= 1.25**2) & (rho <= 1.7**2)
    if not ring.any():
        return 0.0
    r = red[y0:y1, x0:x1].astype(np.float32)
    surface = band[y0:y1, x0:x1]
    if extra is not None:
        local, (ex, ey) = extra
        ox0, oy0 = max(x0, ex), max(y0, ey)
        ox1, oy1 = min(x1, ex + local.shape[1]), min(y1, ey + local.shape[0])
        if ox0 < ox1 and oy0 < oy1:
            surface = surface.copy()
            surface[oy0 - y0 : oy1 - y0, ox0 - x0 : ox1 - x0] |= local[
                oy0 - ey : oy1 - ey, ox0 - ex : ox1 - ex
            ]
    same = surface & (r >= 0.5 * level) & (r <= 2.0 * level)
    return float(np.count_nonzero(same & ring)) / float(np.count_nonzero(ring))
