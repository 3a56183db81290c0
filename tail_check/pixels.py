"""Fast whole-image statistics on uint8 pictures, bit for bit what numpy/OpenCV's plain calls
give, from 256-level tables and histograms (the tail check's hot path measures every frame).
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from .shape import ramp

__all__ = [
    "channel_extreme",
    "clip_window",
    "median_u8",
    "percentile_u8",
    "quantile_f32_u8",
    "std_u8",
    "subtract_level",
    "veil_level",
]


def clip_window(
    shape: tuple[int, ...], x0: int, y0: int, x1: int, y1: int
) -> tuple[int, int, int, int] | None:
    """The window ``[x0, x1) x [y0, y1)`` clipped to an image of ``shape`` (rows, cols, ...),
    or None when none of it lies inside. Clipping both ends keeps a window beyond the top or
    left edge from turning into a negative slice end, which numpy counts from the far edge."""
    rows, cols = shape[0], shape[1]
    x0, x1 = min(max(0, x0), cols), min(max(0, x1), cols)
    y0, y1 = min(max(0, y0), rows), min(max(0, y1), rows)
    if x1 <= x0 or y1 <= y0:
        return None
    return x0, y0, x1, y1


def veil_level(image: NDArray[np.uint8], *, floor: float = 15.0, onset: float = 25.0) -> float:
    """Grey veil (fog, snow haze, glare) estimated from the dark channel, 0..255.

    A clear scene always has near-black pixels (shadows under the car, the buffer
    beam); fog lifts them all by the airlight. The veil is the darkest pixels' level
    ``d`` less ``floor`` (those pixels are dark grey, not black), faded in from
    ``d = onset`` to ``2 * onset`` so that clear images are left as they are.
    """
    dark = percentile_u8(channel_extreme(image, cv2.min), 2)
    return max(0.0, dark - floor) * ramp(dark, onset, 2 * onset)


def channel_extreme(image: NDArray[np.uint8], op: Any) -> NDArray[np.uint8]:
    """Per-pixel minimum (``op=cv2.min``) or maximum (``cv2.max``) over the 3 channels.

    The same values as ``image.min(axis=2)``; numpy reduces a length-3 axis one
    element at a time, OpenCV's element-wise ops are vectorised (about 20x faster)."""
    b, g, r = cv2.split(image)
    return np.asarray(op(op(b, g), r), dtype=np.uint8)


def _histogram(values: NDArray[np.uint8]) -> NDArray[np.float32]:
    """Counts of the 256 levels of a uint8 array (OpenCV: one pass, no sort)."""
    counts = cv2.calcHist([np.ascontiguousarray(values)], [0], None, [256], [0, 256])
    return np.asarray(counts, np.float32).ravel()


def _cumulative(values: NDArray[np.uint8]) -> NDArray[np.int64]:
    """Running count of values at or below each level; its last entry is their number."""
    return np.cumsum(_histogram(values).astype(np.int64))


def _order_statistic(cum: NDArray[np.int64], k: int) -> int:
    """The ``k``-th smallest value (0-based) of the values counted by ``cum``."""
    return int(np.searchsorted(cum, k, side="right"))


def _interpolated(values: NDArray[np.uint8], fraction: float, number: Any) -> float:
    """numpy's default (linear) quantile at ``fraction`` of the values, with the two order
    statistics and the interpolation carried in ``number`` (``float``: numpy on the uint8
    array; ``np.float32``: numpy on the values as float32)."""
    cum = _cumulative(values)
    n = int(cum[-1])
    position = (n - 1) * fraction
    lo = min(math.floor(position), n - 1)
    gamma = position - lo
    below = number(_order_statistic(cum, lo))
    above = number(_order_statistic(cum, min(lo + 1, n - 1)))
    step = above - below
    # numpy's lerp: from the nearer end, so that gamma near 1 rounds like numpy does (a
    # Python float keeps a numpy type's precision).
    return float(below + step * gamma if gamma < 0.5 else above - step * (1 - gamma))


def percentile_u8(values: NDArray[np.uint8], q: float) -> float:
    """``np.percentile(values, q)`` (its default linear method, bit for bit) of a uint8
    array, from a 256-bin histogram instead of a partition of all its values."""
    return _interpolated(values, q / 100, float)


def quantile_f32_u8(values: NDArray[np.uint8], q: float) -> float:
    """``np.quantile(values.astype(np.float32), q)`` bit for bit (numpy interpolates
    between the two order statistics in float32), from a 256-bin histogram."""
    return _interpolated(values, q, np.float32)


def median_u8(values: NDArray[np.uint8]) -> np.float32:
    """``np.median`` of a uint8 array's values as float32 (the median of the same values
    as float32, bit for bit: an even count gives the mean of the two middle values,
    exact in float32), from a 256-bin histogram instead of a partition."""
    cum = _cumulative(values)
    n = int(cum[-1])
    upper = np.float32(_order_statistic(cum, n // 2))
    if n % 2:
        return upper
    lower = np.float32(_order_statistic(cum, n // 2 - 1))
    return np.float32((lower + upper) / np.float32(2))


def std_u8(values: NDArray[np.uint8]) -> float:
    """Standard deviation (``values.std()``) of a uint8 array from its 256-bin histogram."""
    counts = _histogram(values).astype(np.float64)
    n = float(counts.sum())
    mean = float(counts @ _LEVELS) / n
    return math.sqrt(float(counts @ (_LEVELS - mean) ** 2) / n)


_LEVELS = np.arange(256, dtype=np.float64)


def subtract_level(image: NDArray[np.uint8], level: float) -> NDArray[np.uint8]:
    """``cv2.subtract(image, level)`` on every channel (saturating, OpenCV's rounding).

    A fractional scalar makes OpenCV subtract in floating point, ten times slower than
    a table look-up; the table is that same subtraction applied to the 256 levels."""
    if level <= 0:
        return image
    table = cv2.subtract(_LEVELS_U8, np.full(3, level, np.float64))[0, :, 0]
    return np.asarray(cv2.LUT(image, np.ascontiguousarray(table)), dtype=np.uint8)


_LEVELS_U8 = np.repeat(np.arange(256, dtype=np.uint8).reshape(1, 256, 1), 3, axis=2)
