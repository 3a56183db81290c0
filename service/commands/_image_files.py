"""Image files for the tail-check CLI commands: read, bounded and decoded as the service
decodes snapshots, with depot's message (naming the file and the fix) instead of the
decoders' own."""

from __future__ import annotations

import io
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import cv2
import numpy as np
from PIL import Image, UnidentifiedImageError

from core.settings import get_settings
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
    """The file's bytes, once its header declares no more pixels than the service takes."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise ValueError(
            f"cannot read image {path!r} (missing, or not a JPEG/PNG file: {exc.strerror})"
        ) from None
    _check_pixels(path, data)
    return data


def _check_pixels(path: str, data: bytes) -> None:
    """Refuse, from the header alone, an image larger than ``DEPOT_MAX_IMAGE_PIXELS`` (the
    service's limit): a PNG of a few hundred bytes can declare 30000x30000 pixels, which
    the decoder would allocate (2.7 GB) before finding the data missing. A header PIL
    cannot read is left to the decoder's own message."""
    limit = get_settings().max_image_pixels
    pil_limit = Image.MAX_IMAGE_PIXELS  # PIL's own bomb check would hide the size
    Image.MAX_IMAGE_PIXELS = None  # the CLI is one thread (see decoders_quiet)
    try:
        with Image.open(io.BytesIO(data)) as image:
            width, height = image.size
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError):
        return
    finally:
        Image.MAX_IMAGE_PIXELS = pil_limit
    if width * height > limit:
        raise ValueError(
            f"image {path!r} is {width}×{height} pixels, over the limit of {limit} pixels"
            " (DEPOT_MAX_IMAGE_PIXELS, as the service); give a smaller image or raise the limit"
        )


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
