"""Overlay for the review screen: search region, candidates, disc box and verdict."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, cast

import cv2
import numpy as np
from numpy.typing import NDArray

from .detect import BBox, DetectionResult, Verdict, check_image, region_box
from .profile import CameraProfile

__all__ = ["overlay_caption", "overlay_png", "recorded_result", "render_overlay"]

# BGR colours: green = present, amber = uncertain, red = absent.
_VERDICT_COLOUR = {"present": (60, 200, 60), "uncertain": (0, 190, 255), "absent": (40, 40, 230)}
_REGION_COLOUR = (255, 220, 0)
_CANDIDATE_COLOUR = (170, 170, 170)


def _dashed_rect(
    img: NDArray[np.uint8], box: tuple[int, int, int, int], colour: tuple[int, int, int], thick: int
) -> None:
    x, y, w, h = box
    dash = max(4, thick * 4)
    corners = [
        ((x, y), (x + w, y)),
        ((x + w, y), (x + w, y + h)),
        ((x + w, y + h), (x, y + h)),
        ((x, y + h), (x, y)),
    ]
    for (x0, y0), (x1, y1) in corners:
        length = max(abs(x1 - x0), abs(y1 - y0))
        for s in range(0, length, 2 * dash):
            e = min(length, s + dash)
            p0 = (x0 + (x1 - x0) * s // max(length, 1), y0 + (y1 - y0) * s // max(length, 1))
            p1 = (x0 + (x1 - x0) * e // max(length, 1), y0 + (y1 - y0) * e // max(length, 1))
            cv2.line(img, p0, p1, colour, thick, cv2.LINE_AA)


def render_overlay(
    image_bgr: NDArray[np.uint8], result: DetectionResult, profile: CameraProfile | None = None
) -> NDArray[np.uint8]:
    """Draw the detection on a copy of the snapshot.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8
        The snapshot the result was computed on (BGR). Not modified.
    result : DetectionResult
        Output of :func:`tail_check.detect` for this image.
    profile : CameraProfile, optional
        Draw this profile's search region instead of the one stored in ``result``.

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
        BGR image with the search region (dashed), other candidates (grey), the disc
        box (verdict colour) and a banner with verdict, score and ``ŝ``.
    """
    image = check_image(image_bgr)
    if (image.shape[1], image.shape[0]) != tuple(result.image_size):
        raise ValueError(
            f"result is for a {result.image_size[0]}x{result.image_size[1]} image, "
            f"got {image.shape[1]}x{image.shape[0]}"
        )
    out = image.copy()
    thick = max(1, round(min(out.shape[:2]) / 300))
    region = result.search_region
    if profile is not None:
        region = region_box(profile, out.shape[1], out.shape[0])
    _dashed_rect(out, region, _REGION_COLOUR, thick)
    for cand in result.candidates[1:6]:
        x, y, w, h = cand.bbox
        cv2.rectangle(out, (x, y), (x + w, y + h), _CANDIDATE_COLOUR, thick)
    colour = _VERDICT_COLOUR[result.verdict]
    if result.bbox is not None:
        x, y, w, h = result.bbox
        cv2.rectangle(out, (x, y), (x + w, y + h), colour, 2 * thick)
    text = overlay_caption(result)
    font_scale = max(0.4, out.shape[1] / 1400)
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, font_scale, thick)
    cv2.rectangle(out, (0, 0), (min(out.shape[1], tw + 12), th + base + 10), (20, 20, 20), -1)
    cv2.putText(
        out, text, (6, th + 5), cv2.FONT_HERSHEY_SIMPLEX, font_scale, colour, thick, cv2.LINE_AA
    )
    return out


def recorded_result(record: Mapping[str, Any]) -> DetectionResult:
    """A stored verdict (:meth:`DetectionResult.to_dict`, or a two-camera comparison's,
    whose boxes are its arrival image's) as a result to draw.

    The overlay must show what was decided: detecting again drew the hand-tuned detector's
    own answer, a green ``PRESENT`` on a snapshot the learned verifier had held
    ``uncertain``. The candidates are not stored, so none are drawn.

    Raises
    ------
    KeyError
        When ``record`` lacks the verdict, score, search region or image size.
    """
    geometry: Mapping[str, Any] = record.get("arrival") or record
    box = geometry.get("bbox")
    return DetectionResult(
        verdict=cast(Verdict, record["verdict"]),
        score=float(record["score"]),
        bbox=cast(BBox, tuple(int(v) for v in box)) if box else None,
        pixel_fraction=float(geometry.get("pixel_fraction", 0.0)),
        disc_score=float(geometry.get("disc_score", 0.0)),
        quality=float(geometry.get("quality", 1.0)),
        search_region=cast(BBox, tuple(int(v) for v in geometry["search_region"])),
        image_size=cast(tuple[int, int], tuple(int(v) for v in geometry["image_size"])),
        candidates=(),
        reasons=tuple(str(r) for r in record.get("reasons", ())),
    )


def overlay_caption(result: DetectionResult) -> str:
    """The overlay's one line, in plain ASCII (OpenCV's fonts draw no accents: no ``ŝ``)."""
    return (
        f"tail disc {result.verdict.upper()}  score {result.score:.2f} (1.00 = certain)  "
        f"red area {result.pixel_fraction:.2%}"
    )


def overlay_png(
    image_bgr: NDArray[np.uint8], result: DetectionResult, profile: CameraProfile | None = None
) -> bytes:
    """The overlay of :func:`render_overlay` encoded as PNG bytes (for ``/overlay``)."""
    ok, buf = cv2.imencode(".png", render_overlay(image_bgr, result, profile))
    if not ok:  # pragma: no cover - OpenCV encodes any valid uint8 BGR image
        raise RuntimeError("PNG encoding failed")
    return bytes(buf.tobytes())
