"""The paper's ε(c_Δ) study: extraction error for box, disk and Gaussian pre-filters.

For each labelled image with a disc: pick ``c_ref`` inside the disc (the labelled
point), low-pass the image, accept pixels within ``c_ref ± c_Δ·mean(c_ref)`` on every
RGB component (fixed band, as in the paper), and compare the accepted fraction ``ŝ``
with the disc's true fraction ``s_ref``: ``ε = |s_ref − ŝ|``.

The paper's photographs frame the rear of the last car closely; a tail-camera
snapshot is wider. Both fractions are therefore taken over the disc's neighbourhood
(the labelled disc box widened to ``window`` times its size, the car's rear around
the disc), not over the whole snapshot, where any stray pixel would dominate a
disc covering a fraction of a percent.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from .colour import FILTER_KINDS, FilterKind, band_mask, low_pass
from .detect import WORK_SIDE, check_image

__all__ = ["DEFAULT_DELTAS", "StudyResult", "StudySample", "epsilon_curves", "extraction_error"]

DEFAULT_DELTAS: tuple[float, ...] = tuple(round(0.05 * i, 2) for i in range(1, 21))


@dataclass(frozen=True)
class StudySample:
    """One labelled image: BGR pixels, the disc's pixel fraction of the whole image,
    a point inside the disc and the disc's box (x, y, w, h), in image pixels."""

    image_bgr: NDArray[np.uint8]
    s_ref: float
    reference_point: tuple[int, int]
    disc_box: tuple[int, int, int, int]
    group: str = ""


@dataclass(frozen=True)
class StudyResult:
    """Mean ε (as a fraction of the image) per filter and ``c_Δ``.

    Attributes
    ----------
    deltas : tuple of float
        The ``c_Δ`` values (fractions of ``mean(c_ref)``).
    mean_error : dict
        ``{filter: array (len(deltas),)}`` mean ε over the images.
    median_error : dict
        Same, median.
    count : int
        Images used.
    kernel_size : int
        Filter size N in working pixels.
    """

    deltas: tuple[float, ...]
    mean_error: dict[str, NDArray[np.float64]]
    median_error: dict[str, NDArray[np.float64]]
    count: int
    kernel_size: int

    def best_filter(self, delta: float = 0.25) -> str:
        """The filter with the lowest mean ε at the ``c_Δ`` closest to ``delta``."""
        i = int(np.argmin(np.abs(np.asarray(self.deltas) - delta)))
        return min(self.mean_error, key=lambda k: float(self.mean_error[k][i]))

    def table(self) -> str:
        """Plain-text table: ``c_Δ`` % against mean ε % for each filter."""
        kinds = list(self.mean_error)
        lines = [
            "c_delta%  "
            + "  ".join(f"{k:>9s}" for k in kinds)
            + "   (mean eps, % of the disc neighbourhood)"
        ]
        for i, d in enumerate(self.deltas):
            cells = "  ".join(f"{100 * self.mean_error[k][i]:9.4f}" for k in kinds)
            lines.append(f"{100 * d:7.0f}   {cells}")
        return "\n".join(lines)


def _to_work(image: NDArray[np.uint8]) -> tuple[NDArray[np.uint8], float]:
    h, w = image.shape[:2]
    scale = WORK_SIDE / math.sqrt(w * h)
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
    return np.asarray(cv2.resize(image, size, interpolation=interp), dtype=np.uint8), scale


def extraction_error(
    filtered_bgr: NDArray[np.float32],
    s_ref: float,
    reference_rgb: tuple[float, float, float],
    c_delta: float,
) -> float:
    """``ε = |s_ref − ŝ|`` for one filtered image and one band (fixed gain, as in the paper).

    Parameters
    ----------
    filtered_bgr : ndarray (H, W, 3)
        Low-passed BGR image.
    s_ref : float
        True disc pixel fraction (0..1).
    reference_rgb : tuple of 3 float
        ``c_ref`` (RGB).
    c_delta : float
        Band half-width as a fraction of ``mean(c_ref)``.
    """
    mask = band_mask(filtered_bgr, reference_rgb, c_delta)
    return abs(float(s_ref) - float(np.count_nonzero(mask)) / mask.size)


def epsilon_curves(
    samples: Iterable[StudySample],
    *,
    deltas: Sequence[float] = DEFAULT_DELTAS,
    kinds: Sequence[FilterKind] = FILTER_KINDS,
    kernel_fraction: float = 0.02,
    window: float = 3.0,
) -> StudyResult:
    """ε(c_Δ) curves over a labelled set, one per pre-filter.

    Parameters
    ----------
    samples : iterable of StudySample
        Images with a disc (``s_ref > 0``); others are skipped.
    deltas : sequence of float
        ``c_Δ`` values to try (fractions, e.g. 0.25).
    kinds : sequence of {"box", "disk", "gaussian"}
    kernel_fraction : float
        Filter size N as a fraction of ``sqrt(W*H)`` (same N for every filter; the
        Gaussian uses ``σ = N/4``, as MATLAB's ``fspecial`` would with that support).
    window : float
        Size of the analysed neighbourhood in disc-box sizes (>= 1.2).

    Returns
    -------
    StudyResult
    """
    if not deltas or any(d <= 0 for d in deltas):
        raise ValueError("deltas must be a non-empty list of positive fractions")
    size = max(3, int(round(kernel_fraction * WORK_SIDE)) | 1)
    errors: dict[str, list[list[float]]] = {k: [] for k in kinds}
    count = 0
    if window < 1.2:
        raise ValueError(f"window must be >= 1.2 disc sizes, got {window}")
    for sample in samples:
        if sample.s_ref <= 0:
            continue
        image = check_image(sample.image_bgr)
        work, scale = _to_work(image)
        px = min(work.shape[1] - 1, int(sample.reference_point[0] * scale))
        py = min(work.shape[0] - 1, int(sample.reference_point[1] * scale))
        r = max(1, size // 4)
        patch = work[max(0, py - r) : py + r + 1, max(0, px - r) : px + r + 1].reshape(-1, 3)
        ref_bgr = np.median(patch, axis=0)
        ref = (float(ref_bgr[2]), float(ref_bgr[1]), float(ref_bgr[0]))
        x, y, w, h = (v * scale for v in sample.disc_box)
        cx, cy, half_w, half_h = x + w / 2, y + h / 2, window * w / 2, window * h / 2
        x0, x1 = max(0, int(cx - half_w)), min(work.shape[1], int(cx + half_w) + 1)
        y0, y1 = max(0, int(cy - half_h)), min(work.shape[0], int(cy + half_h) + 1)
        if sum(ref) <= 0 or x1 - x0 < 3 or y1 - y0 < 3:
            continue
        s_ref = min(1.0, sample.s_ref * work.shape[0] * work.shape[1] / ((x1 - x0) * (y1 - y0)))
        count += 1
        for kind in kinds:
            filtered = low_pass(work, kind, size)[y0:y1, x0:x1]
            errors[kind].append([extraction_error(filtered, s_ref, ref, d) for d in deltas])
    if count == 0:
        raise ValueError("no labelled image with a disc (s_ref > 0 and a reference point)")
    mean = {k: np.asarray(v, float).mean(axis=0) for k, v in errors.items()}
    median = {k: np.median(np.asarray(v, float), axis=0) for k, v in errors.items()}
    return StudyResult(tuple(float(d) for d in deltas), mean, median, count, size)
