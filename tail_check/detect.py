"""Red tail-disc detection on one last-car snapshot.

Pipeline (paper + spec): crop the search region, bring it to a fixed working scale
(so nothing depends on the image size), Gaussian low-pass, per-channel band
``c_ref ± c_Δ``, connected regions, disc-consistency checks (size relative to the
image, fill ratio, ellipse fit, solidity, holes, aspect; or, for a disc partly behind a
pole, an elliptic arc cut by a straight edge that the occluder continues), verdict.

Safety stance: a false ``present`` can clear a section with cars still in it, so
weak evidence yields ``uncertain`` and poor images lower the confidence of ``absent``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import cv2
import numpy as np
from numpy.typing import NDArray

from .colour import band_mask
from .passes import search_passes
from .pixels import channel_extreme, percentile_u8, std_u8, subtract_level, veil_level
from .profile import DEFAULT_PROFILE, CameraProfile
from .regions import DiscCandidate
from .shape import ramp

__all__ = [
    "WORK_SIDE",
    "DetectionResult",
    "DiscCandidate",
    "Verdict",
    "check_image",
    "detect",
    "detect_reduced",
]

Verdict = Literal["present", "absent", "uncertain"]
BBox = tuple[int, int, int, int]

MIN_RESOLVED_PX = 12
"""A disc fewer image pixels across than this cannot be told from a small hand wheel or
lamp: the verdict stays ``uncertain`` however disc-like the blurred region looks."""
WORK_SIDE = 400.0
"""Geometric-mean side ``sqrt(W*H)`` (pixels) of the working image: every snapshot is
resampled to this scale before filtering, so the result does not depend on its size."""


@dataclass(frozen=True)
class DetectionResult:
    """Verdict of the tail-disc detector on one image.

    Attributes
    ----------
    verdict : {"present", "absent", "uncertain"}
    score : float
        Confidence 0..1 in the verdict: the disc score for ``present``, the confidence
        that no disc is there for ``absent``, the best disc score for ``uncertain``.
    bbox : (x, y, w, h) or None
        The disc's box in pixels (best candidate, also for ``uncertain``).
    pixel_fraction : float
        ``ŝ``: band-accepted pixels inside the search region / all image pixels.
    disc_score : float
        Best disc-consistency score found (0 when no candidate).
    quality : float
        0..1, how well the image could show a disc (exposure, contrast, red clutter).
    search_region : (x, y, w, h)
        The searched box in pixels.
    image_size : (width, height)
    candidates : tuple of DiscCandidate
        Candidates, best first.
    reasons : tuple of str
        Plain-language reasons for the verdict.
    """

    verdict: Verdict
    score: float
    bbox: BBox | None
    pixel_fraction: float
    disc_score: float
    quality: float
    search_region: BBox
    image_size: tuple[int, int]
    candidates: tuple[DiscCandidate, ...]
    reasons: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (the public fields plus quality and reasons)."""
        return {
            "verdict": self.verdict,
            "score": round(self.score, 4),
            "bbox": list(self.bbox) if self.bbox is not None else None,
            "pixel_fraction": round(self.pixel_fraction, 6),
            "disc_score": round(self.disc_score, 4),
            "quality": round(self.quality, 4),
            "search_region": list(self.search_region),
            "image_size": list(self.image_size),
            "reasons": list(self.reasons),
        }


MIN_SIDE = 16
"""Fewest pixels across and high of an image the detector judges (the service refuses
smaller uploads with this figure)."""


def check_image(image_bgr: object) -> NDArray[np.uint8]:
    """Validate a BGR snapshot and return it as a uint8 array (no copy when possible).

    Another numeric type is accepted when every value lies in 0..255 (a float image of
    8-bit values); anything else (a 16-bit image, floats scaled to 0..1 aside) is refused,
    never clipped: 60000 of a uint16 image would silently have become a white 255.

    Raises
    ------
    ValueError
        If it is not an (H, W, 3) image of at least MIN_SIDE×MIN_SIDE pixels with values 0..255.
    """
    if not isinstance(image_bgr, np.ndarray):
        raise ValueError(f"image must be a numpy array (BGR), got {type(image_bgr).__name__}")
    if image_bgr.ndim != 3 or image_bgr.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W, 3) in BGR order, got {image_bgr.shape}")
    height, width = image_bgr.shape[:2]
    if height < MIN_SIDE or width < MIN_SIDE:
        size = f"({width}x{height})"
        if height >= MIN_SIDE:
            raise ValueError(f"image is too narrow {size}, need at least {MIN_SIDE} pixels across")
        if width >= MIN_SIDE:
            raise ValueError(f"image is too short {size}, need at least {MIN_SIDE} pixels high")
        raise ValueError(f"image is too small {size}, need at least {MIN_SIDE}x{MIN_SIDE}")
    if image_bgr.dtype == np.uint8:
        return image_bgr
    real = np.issubdtype(image_bgr.dtype, np.integer) or np.issubdtype(image_bgr.dtype, np.floating)
    if not real or not np.all(np.isfinite(image_bgr)):
        raise ValueError("image must hold finite numbers 0..255")
    low, high = float(image_bgr.min()), float(image_bgr.max())
    if low < 0 or high > 255:
        raise ValueError(
            f"image must hold 8-bit values 0..255 (BGR uint8), got {image_bgr.dtype} values"
            f" from {low:g} to {high:g}; convert it to uint8 first"
        )
    return np.asarray(image_bgr, dtype=np.uint8)


def region_box(profile: CameraProfile, width: int, height: int) -> BBox:
    """The profile's search region in pixels, as (x, y, w, h)."""
    x0, y0, x1, y1 = profile.search_region
    left, top = int(math.floor(x0 * width)), int(math.floor(y0 * height))
    right, bottom = int(math.ceil(x1 * width)), int(math.ceil(y1 * height))
    return left, top, max(1, right - left), max(1, bottom - top)


def _working_crop(
    image: NDArray[np.uint8], box: BBox, scale: float, full_size: tuple[int, int]
) -> NDArray[np.uint8]:
    """The search region at the working scale. ``box`` and ``scale`` are in pixels of the
    snapshot (``full_size``); ``image`` may be that snapshot decoded at a reduced size."""
    x, y, w, h = box
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    fx, fy = image.shape[1] / full_size[0], image.shape[0] / full_size[1]
    if fx == 1 and fy == 1:
        crop = image[y : y + h, x : x + w]
        interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
    else:
        x0, y0 = int(math.floor(x * fx)), int(math.floor(y * fy))
        x1, y1 = int(math.ceil((x + w) * fx)), int(math.ceil((y + h) * fy))
        crop = image[y0 : max(y1, y0 + 1), x0 : max(x1, x0 + 1)]
        # A reduced decode is usually less than 2x the working scale (ReducedDecode keeps
        # one decoded pixel per working pixel, the decoder halves): bilinear is about
        # as smooth as pixel-area averaging there, at a seventh of its time.
        near = crop.shape[1] <= 2 * size[0] and crop.shape[0] <= 2 * size[1]
        interp = cv2.INTER_LINEAR if near else cv2.INTER_AREA
    return np.asarray(cv2.resize(crop, size, interpolation=interp), dtype=np.uint8)


_THREE_QUARTERS = np.array([(3 * v + 3) // 4 for v in range(256)], dtype=np.uint8)


def _not_in_valley(image: NDArray[np.uint8], sigma_px: float) -> NDArray[np.bool_]:
    """False on dark seams (the disc's rim, its shadow, rib edges) between bright areas.

    The band accepts any exposure gain, so a dark rim between the disc and a red car
    body passes it; this cuts such seams so the disc stays a region of its own. It
    looks at the image before the full low-pass, which would fill a thin rim in.
    """
    red = cv2.GaussianBlur(image[..., 2], (0, 0), min(sigma_px, 0.8))
    size = 2 * max(2, round(2.0 * sigma_px)) + 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    # Closing fills seams narrower than the kernel; a pixel well below its closing
    # lies in such a seam. Broad dark areas (a shaded disc) are not touched.
    closed = cv2.morphologyEx(red, cv2.MORPH_CLOSE, kernel)
    # red >= 0.75 * closed, in integers: red >= ceil(3 * closed / 4).
    below = cv2.compare(red, cv2.LUT(closed, _THREE_QUARTERS), cv2.CMP_GE)
    return np.asarray(cv2.min(below, 1), dtype=np.uint8).view(bool)


def _quality(smooth: NDArray[np.uint8], red_share: float) -> tuple[float, list[str]]:
    """How well a disc would show: exposure, contrast and red clutter in the region."""
    grey = np.asarray(cv2.cvtColor(smooth, cv2.COLOR_BGR2GRAY), dtype=np.uint8)
    bright = percentile_u8(channel_extreme(smooth, cv2.max), 90)
    contrast = std_u8(grey)
    q_exposure = ramp(bright, 20.0, 70.0, 254.0, 256.0)
    q_contrast = ramp(contrast, 4.0, 16.0)
    q_clutter = 1.0 - 0.6 * ramp(red_share, 0.08, 0.30)
    notes = []
    if q_exposure < 0.6:
        notes.append("image dark or over-exposed")
    if q_contrast < 0.6:
        notes.append("low contrast (fog, glare or blur)")
    if q_clutter < 0.8:
        notes.append("much disc-coloured surface in the search region (red car?)")
    return min(q_exposure, q_contrast) * q_clutter, notes


def _verdict(
    best: DiscCandidate | None, quality: float, notes: list[str], p: CameraProfile
) -> tuple[Verdict, float, list[str]]:
    disc = best.score if best is not None else 0.0
    if best is not None and best.glow is not None:
        return "uncertain", disc, [best.glow, *notes]
    if best is not None and disc >= p.present_threshold:
        if max(best.bbox[2:]) < MIN_RESOLVED_PX:
            return "uncertain", disc, ["disc-like red region too few pixels across to be sure"]
        return "present", disc, [f"disc-shaped red region, disc score {disc:.2f}"]
    if disc >= p.uncertain_threshold:
        return "uncertain", disc, [f"red region only partly disc-like (score {disc:.2f})", *notes]
    if quality < 0.05:
        return "uncertain", disc, ["image cannot show a disc reliably", *notes]
    reason = "no disc-shaped red region in the search region"
    return "absent", (1.0 - disc) * quality, [reason, *notes]


def detect(image_bgr: NDArray[np.uint8], profile: CameraProfile | None = None) -> DetectionResult:
    """Detect the red tail disc on a last-car snapshot.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
        The snapshot in BGR order (as OpenCV decodes it). Not modified.
    profile : CameraProfile, optional
        Camera profile; :data:`DEFAULT_PROFILE` (standard signal red) when omitted.

    Returns
    -------
    DetectionResult

    Raises
    ------
    ValueError
        If the image is not a BGR array of at least 16×16 pixels.
    """
    image = check_image(image_bgr)
    return detect_reduced(image, profile, full_size=(image.shape[1], image.shape[0]))


def detect_reduced(
    image_bgr: NDArray[np.uint8],
    profile: CameraProfile | None = None,
    *,
    full_size: tuple[int, int],
) -> DetectionResult:
    """:func:`detect` on a snapshot of ``full_size`` (width, height) decoded at a reduced
    size (the JPEG decoder's DCT-domain reduction, see :mod:`tail_check.snapshot`).

    Boxes, sizes and the search region are reported in pixels of the full snapshot. The
    working image is the same size as from the full image; it only comes from fewer
    pixels. With ``full_size`` equal to the image's own size this is :func:`detect`.
    """
    image = check_image(image_bgr)
    p = profile if profile is not None else DEFAULT_PROFILE
    width, height = int(full_size[0]), int(full_size[1])
    if width < image.shape[1] or height < image.shape[0]:
        raise ValueError(f"full_size {full_size} is smaller than the image {image.shape[1::-1]}")
    box = region_box(p, width, height)
    scale = WORK_SIDE / math.sqrt(width * height)
    work = _working_crop(image, box, scale, (width, height))
    sigma_px = p.sigma * WORK_SIDE
    smooth = work
    if sigma_px >= 0.3:
        smooth = np.asarray(cv2.GaussianBlur(work, (0, 0), sigma_px), dtype=np.uint8)
    veil = veil_level(smooth)
    smooth = subtract_level(smooth, veil)
    band = band_mask(smooth, p.reference_rgb, p.c_delta, gain_range=p.gain_range)
    clear = subtract_level(work, veil)
    valley_free = _not_in_valley(clear, sigma_px)
    mask = band & valley_free
    accepted = float(np.count_nonzero(mask))
    candidates = search_passes(
        smooth,
        clear,
        band,
        valley_free,
        p,
        work=work,
        origin=box[:2],
        scale=scale,
        sigma_px=sigma_px,
        work_side=WORK_SIDE,
    )
    quality, notes = _quality(smooth, accepted / max(1.0, float(mask.size)))
    best = candidates[0] if candidates else None
    verdict, score, reasons = _verdict(best, quality, notes, p)
    return DetectionResult(
        verdict=verdict,
        score=min(1.0, max(0.0, float(score))),
        bbox=best.bbox if best is not None and verdict != "absent" else None,
        pixel_fraction=accepted / (WORK_SIDE * WORK_SIDE),
        disc_score=best.score if best is not None else 0.0,
        quality=quality,
        search_region=box,
        image_size=(width, height),
        candidates=tuple(candidates),
        reasons=tuple(reasons),
    )
