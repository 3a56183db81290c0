"""Image files for the tail-check CLI commands: read, bounded and decoded as the service
decodes snapshots, with depot's message (naming the file and the fix) instead of the
decoders' own."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

import cv2
import numpy as np

from core.errors import DepotError, PayloadTooLarge
from core.settings import get_settings
from ingest.snapshots import check_image
from tail_check import UndecodableImage, decode_snapshot

__all__ = ["decoders_quiet", "read_bytes", "read_image", "unreadable"]


@contextmanager
def decoders_quiet() -> Iterator[None]:
    """Silence OpenCV's log and what libjpeg/libpng write to the process's stderr themselves
    (``Corrupt JPEG data: ...``, ``libpng error: ...``): depot's message says what matters.

    The CLI is one thread; the service (threads) must never swap its stderr like this.
    """
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        quiet = os.open(os.devnull, os.O_WRONLY)
        os.dup2(quiet, 2)
        os.close(quiet)
        yield
    finally:
        sys.stderr.flush()
        os.dup2(saved, 2)
        os.close(saved)
        cv2.utils.logging.setLogLevel(level)


def read_bytes(path: str) -> bytes:
    """The file's bytes, once the service's own check of an upload takes them
    (:func:`ingest.snapshots.check_image`: JPEG or PNG, whole, within the service's byte and
    pixel limits, at least 16x16): the CLI judged BMP, GIF and WebP files the service
    refuses, read a 3 GB file or ``/dev/zero`` whole, and had its own pixel check."""
    settings = get_settings()
    limit = settings.max_image_bytes
    try:
        with open(path, "rb") as handle:
            data = handle.read(limit + 1)  # never more than the limit: a device has no size
    except OSError as exc:
        raise ValueError(
            f"cannot read image {path!r} (missing, or not a JPEG/PNG file: {exc.strerror})"
        ) from None
    if len(data) > limit:
        raise ValueError(
            f"image {path!r} has more than {limit} bytes, over the limit (DEPOT_MAX_IMAGE_BYTES,"
            " as the service); give a smaller image or raise the limit"
        )
    try:
        check_image(data, max_bytes=limit, max_pixels=settings.max_image_pixels)
    except PayloadTooLarge as exc:
        raise ValueError(
            f"image {path!r} is too large ({exc.detail}; DEPOT_MAX_IMAGE_PIXELS, as the"
            " service); give a smaller image or raise the limit"
        ) from None
    except DepotError as exc:
        raise ValueError(f"cannot read image {path!r} ({exc.detail})") from None
    return data


def unreadable(path: str, exc: UndecodableImage) -> ValueError:
    return ValueError(f"cannot read image {path!r} (not a whole JPEG/PNG file: {exc})")


def read_image(path: str) -> np.ndarray:
    """The image's pixels as the service decodes them (EXIF orientation ignored)."""
    data = read_bytes(path)
    try:
        with decoders_quiet():
            return decode_snapshot(data)
    except UndecodableImage as exc:
        raise unreadable(path, exc) from None
