"""Encoded snapshots: decoding, and detection on a JPEG decoded at reduced size.

The detector works at a fixed scale (``WORK_SIDE``, about 400 pixels of geometric-mean
side), so of a 1920x1080 snapshot it uses one pixel in 3.6 across. A JPEG decoder can
reduce by 2, 4 or 8 in the DCT domain, skipping most of the inverse transform and the
colour conversion, and :func:`detect_snapshot` lets it reduce as far as the working
image still gets enough pixels (:class:`ReducedDecode`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from .confirm import CONFIRM_PARAMS, ConfirmParams, confirm
from .detect import WORK_SIDE, DetectionResult, detect_reduced
from .profile import CameraProfile

__all__ = [
    "DEFAULT_REDUCED_DECODE",
    "ReducedDecode",
    "UndecodableImage",
    "decode_snapshot",
    "detect_snapshot",
    "jpeg_size",
    "reduction_for",
]

# EXIF orientation is ignored everywhere: the service judges (and a profile is calibrated
# on) the pixels as stored, as its own decoder (PIL) does.
_REDUCED = {
    1: cv2.IMREAD_COLOR | cv2.IMREAD_IGNORE_ORIENTATION,
    2: cv2.IMREAD_REDUCED_COLOR_2 | cv2.IMREAD_IGNORE_ORIENTATION,
    4: cv2.IMREAD_REDUCED_COLOR_4 | cv2.IMREAD_IGNORE_ORIENTATION,
    8: cv2.IMREAD_REDUCED_COLOR_8 | cv2.IMREAD_IGNORE_ORIENTATION,
}
# Start-of-frame markers (baseline, extended, progressive, lossless; not DHT, JPG, DAC).
_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}


class UndecodableImage(ValueError):
    """The bytes are not a whole JPEG or PNG image (empty, truncated, another format)."""


@dataclass(frozen=True)
class ReducedDecode:
    """How far :func:`detect_snapshot` lets the JPEG decoder reduce a snapshot.

    Attributes
    ----------
    min_side : float
        The reduced image's geometric-mean side ``sqrt(w*h) / r`` must stay at or above
        this many pixels. ``WORK_SIDE`` keeps at least one decoded pixel per working
        pixel (a 1920x1080 snapshot is decoded at 1/2).
    factors : tuple of int
        Reductions the decoder offers, tried from the largest.
    """

    min_side: float = WORK_SIDE
    factors: tuple[int, ...] = (8, 4, 2)


DEFAULT_REDUCED_DECODE = ReducedDecode()


def decode_snapshot(data: bytes, *, reduce: int = 1) -> NDArray[np.uint8]:
    """Decode JPEG/PNG bytes to a BGR array (EXIF orientation ignored, as
    :func:`detect_snapshot` and the service's decoder do).

    Parameters
    ----------
    data : bytes
        The encoded image.
    reduce : {1, 2, 4, 8}
        Let the JPEG decoder downscale by this factor in the DCT domain (much faster
        for large snapshots; :func:`detect_snapshot` picks the factor itself).

    Raises
    ------
    UndecodableImage
        If the bytes are not a decodable image.
    ValueError
        If ``reduce`` is not 1, 2, 4 or 8.
    """
    if reduce not in _REDUCED:
        raise ValueError(f"reduce must be 1, 2, 4 or 8, got {reduce}")
    if not data:
        raise UndecodableImage("empty image data")
    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), _REDUCED[reduce])
    if image is None:
        raise UndecodableImage("image data is not a decodable JPEG or PNG")
    return np.asarray(image, dtype=np.uint8)


def jpeg_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a JPEG's frame header, without decoding; None when ``data``
    is not a JPEG with a readable header of 1 (grey) or 3 (colour) components."""
    if data[:2] != b"\xff\xd8":
        return None
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte before a marker
            i += 1
            continue
        if marker in (0x01, 0xD8) or 0xD0 <= marker <= 0xD7:  # markers without a length
            i += 2
            continue
        if marker in (0xD9, 0xDA):  # end of image or scan data before any frame header
            return None
        length = int.from_bytes(data[i + 2 : i + 4], "big")
        if marker in _SOF:
            if length < 8 or i + 10 > len(data):
                return None
            height = int.from_bytes(data[i + 5 : i + 7], "big")
            width = int.from_bytes(data[i + 7 : i + 9], "big")
            ok = width > 0 and height > 0 and data[i + 9] in (1, 3)
            return (width, height) if ok else None
        if length < 2:
            return None
        i += 2 + length
    return None


def reduction_for(size: tuple[int, int], params: ReducedDecode = DEFAULT_REDUCED_DECODE) -> int:
    """The largest decoder reduction that keeps ``sqrt(w*h) / r >= params.min_side``."""
    side = math.sqrt(size[0] * size[1])
    for factor in sorted(params.factors, reverse=True):
        if factor in _REDUCED and side / factor >= params.min_side:
            return factor
    return 1


def detect_snapshot(
    data: bytes,
    profile: CameraProfile | None = None,
    *,
    params: ReducedDecode = DEFAULT_REDUCED_DECODE,
    confirmed: ConfirmParams = CONFIRM_PARAMS,
) -> DetectionResult:
    """Decode a snapshot (JPEG at reduced size where that keeps enough pixels) and detect;
    a ``present`` must then be confirmed by the learned verifier (:func:`~.confirm.confirm`).

    EXIF orientation is ignored, as the service's own decoder does. Anything that is not
    a plain JPEG (PNG, CMYK JPEG, an unreadable header, a decoder that does not reduce
    as expected) is decoded in full.

    Raises
    ------
    UndecodableImage
        If the bytes are not a decodable image (empty, truncated, not JPEG or PNG).
    ValueError
        If the image is smaller than 16x16 pixels.
    """
    size = jpeg_size(data)
    factor = reduction_for(size, params) if size is not None else 1
    if size is not None and factor > 1:
        image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), _REDUCED[factor])
        expected = (math.ceil(size[1] / factor), math.ceil(size[0] / factor))
        if image is not None and image.shape[:2] == expected:
            reduced = np.asarray(image, np.uint8)
            return confirm(reduced, detect_reduced(reduced, profile, full_size=size), confirmed)
    full = decode_snapshot(data)  # refuses empty and undecodable data
    result = detect_reduced(full, profile, full_size=(full.shape[1], full.shape[0]))
    return confirm(full, result, confirmed)
