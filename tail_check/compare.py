"""Two-camera comparison: the departure snapshot as reference for the arrival verdict.

The departure image shows the disc as it really was on this run (its colour, size and
place). The arrival image is searched with that disc's colour and size, and the disc
patches of both images are compared block-wise (colour layout on a coarse grid) and
pixel-wise (correlation of the red-chromaticity patches).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from .confirm import detect_confirmed
from .detect import DetectionResult, Verdict, check_image
from .profile import DEFAULT_PROFILE, CameraProfile

__all__ = ["Comparison", "compare", "compare_with_departure", "run_profile"]

_PATCH = 24
_MIN_SIMILARITY = 0.35


@dataclass(frozen=True)
class Comparison:
    """Arrival verdict using the departure snapshot as reference.

    Attributes
    ----------
    verdict : {"present", "absent", "uncertain"}
        Final arrival verdict.
    score : float
        Confidence in ``verdict`` (same meaning as :attr:`DetectionResult.score`).
    departure, arrival : DetectionResult
        The departure detection and the arrival detection (with the run profile
        when the departure disc was seen).
    lost_rear : bool
        Disc present at departure and absent on arrival: strong evidence that the
        rear part of the train was lost.
    similarity : float or None
        0..1 likeness of the arrival disc patch to the departure disc patch.
    reasons : tuple of str
    """

    verdict: Verdict
    score: float
    departure: DetectionResult
    arrival: DetectionResult
    lost_rear: bool
    similarity: float | None
    reasons: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary."""
        return {
            "verdict": self.verdict,
            "score": round(self.score, 4),
            "lost_rear": self.lost_rear,
            "similarity": None if self.similarity is None else round(self.similarity, 4),
            "reasons": list(self.reasons),
            "departure": self.departure.to_dict(),
            "arrival": self.arrival.to_dict(),
        }


def run_profile(departure: DetectionResult, base: CameraProfile) -> CameraProfile:
    """The base profile tuned to the disc seen at departure (its colour and size)."""
    if departure.verdict != "present" or not departure.candidates:
        return base
    disc = departure.candidates[0]
    dmin, dmax = base.disc_diameter_range
    lo = max(0.5 * dmin, 0.6 * disc.diameter)
    hi = min(1.5 * dmax, max(lo * 1.1, 1.6 * disc.diameter))
    return replace(
        base,
        name=f"{base.name}+departure",
        reference_rgb=disc.mean_rgb,
        disc_diameter_range=(lo, hi),
    )


def _patch(image: NDArray[np.uint8], bbox: tuple[int, int, int, int]) -> NDArray[np.float32]:
    """Red chromaticity r/(r+g+b) of the disc box grown by 30 %, resampled to a square."""
    x, y, w, h = bbox
    gx, gy = int(0.3 * w), int(0.3 * h)
    x0, y0 = max(0, x - gx), max(0, y - gy)
    x1, y1 = min(image.shape[1], x + w + gx), min(image.shape[0], y + h + gy)
    crop = cv2.resize(image[y0:y1, x0:x1], (_PATCH, _PATCH), interpolation=cv2.INTER_AREA)
    f = crop.astype(np.float32)
    return np.asarray(f[..., 2] / (f.sum(axis=2) + 1.0), dtype=np.float32)


def patch_similarity(
    departure_bgr: NDArray[np.uint8],
    dep_box: tuple[int, int, int, int],
    arrival_bgr: NDArray[np.uint8],
    arr_box: tuple[int, int, int, int],
) -> float:
    """0..1 likeness of two disc patches: mean of block-wise and pixel-wise agreement."""
    a, b = _patch(departure_bgr, dep_box), _patch(arrival_bgr, arr_box)
    # pixel-wise: normalised cross-correlation of the chromaticity patches
    da, db = a - a.mean(), b - b.mean()
    denom = math.sqrt(float((da * da).sum() * (db * db).sum()))
    ncc = float((da * db).sum()) / denom if denom > 1e-9 else 0.0
    # block-wise: 4x4 block means must agree in red chromaticity
    ba = a.reshape(4, _PATCH // 4, 4, _PATCH // 4).mean(axis=(1, 3))
    bb = b.reshape(4, _PATCH // 4, 4, _PATCH // 4).mean(axis=(1, 3))
    block = 1.0 - min(1.0, float(np.abs(ba - bb).mean()) / 0.15)
    return float(np.clip(0.5 * max(0.0, ncc) + 0.5 * block, 0.0, 1.0))


def compare_with_departure(
    departure: DetectionResult,
    departure_bgr: NDArray[np.uint8],
    arrival_bgr: NDArray[np.uint8],
    profile: CameraProfile | None = None,
) -> Comparison:
    """Arrival verdict given the departure detection and image (see :func:`compare`)."""
    base = profile if profile is not None else DEFAULT_PROFILE
    dep_img, arr_img = check_image(departure_bgr), check_image(arrival_bgr)
    if departure.verdict != "present" or departure.bbox is None:
        arrival = detect_confirmed(arr_img, base)
        reasons = (f"departure disc {departure.verdict}: arrival judged alone", *arrival.reasons)
        return Comparison(arrival.verdict, arrival.score, departure, arrival, False, None, reasons)
    arrival = detect_confirmed(arr_img, run_profile(departure, base))
    if arrival.verdict == "absent":
        reasons = (
            "disc present at departure, absent on arrival: rear part may be lost",
            *arrival.reasons,
        )
        return Comparison("absent", arrival.score, departure, arrival, True, None, reasons)
    if arrival.bbox is None:
        return Comparison(
            arrival.verdict, arrival.score, departure, arrival, False, None, arrival.reasons
        )
    sim = patch_similarity(dep_img, departure.bbox, arr_img, arrival.bbox)
    if arrival.verdict == "present" and sim < _MIN_SIMILARITY:
        reasons = (
            f"arrival disc unlike the departure disc (similarity {sim:.2f})",
            *arrival.reasons,
        )
        return Comparison("uncertain", arrival.score, departure, arrival, False, sim, reasons)
    reasons = (f"arrival disc matches departure disc (similarity {sim:.2f})", *arrival.reasons)
    return Comparison(arrival.verdict, arrival.score, departure, arrival, False, sim, reasons)


def compare(
    departure_bgr: NDArray[np.uint8],
    arrival_bgr: NDArray[np.uint8],
    profile: CameraProfile | None = None,
    *,
    departure_profile: CameraProfile | None = None,
) -> Comparison:
    """Two-camera check: is the disc seen at departure still on the last car on arrival?

    Parameters
    ----------
    departure_bgr, arrival_bgr : ndarray, shape (H, W, 3), uint8
        Snapshots of the last car from the departure and arrival cameras, BGR.
    profile : CameraProfile, optional
        Arrival camera profile (default profile when omitted).
    departure_profile : CameraProfile, optional
        Departure camera profile (``profile`` when omitted).

    Returns
    -------
    Comparison
    """
    dep_profile = departure_profile if departure_profile is not None else profile
    departure = detect_confirmed(departure_bgr, dep_profile)
    return compare_with_departure(departure, departure_bgr, arrival_bgr, profile)
