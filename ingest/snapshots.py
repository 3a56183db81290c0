"""Tail-car snapshot files: validation without trusting the header, content-addressed storage."""

from __future__ import annotations

import fcntl
import hashlib
import io
import os
import tempfile
import warnings
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import simplejpeg
from numpy.typing import NDArray
from PIL import Image, UnidentifiedImageError

from core.errors import PayloadTooLarge, Unprocessable
from tail_check import MIN_SIDE

FORMATS = {"JPEG": ("image/jpeg", ".jpg"), "PNG": ("image/png", ".png")}
SUFFIXES = dict(FORMATS.values())  # content type -> file suffix of the stored image


@dataclass(frozen=True)
class CheckedImage:
    sha256: str
    content_type: str
    suffix: str
    width: int
    height: int


# The multipart form of POST /snapshots (protocol.md): these fields and the file, nothing else.
FORM_FIELDS = ("event_id", "occurred_at", "section")
FORM_FILE = "image"


def check_form_fields(names: Iterable[str]) -> None:
    """Refuse (422, naming them) form fields the protocol does not name: an event refuses an
    unknown field, and a field silently dropped (``camera``, a misspelt ``occured_at``) would
    leave the device's integrator believing it was stored. ``names`` holds every part's name,
    repeats included: a field sent twice is refused too (the form kept the last silently, as
    a JSON event with a repeated key is refused). Missing fields are said elsewhere."""
    names = list(names)
    unknown = sorted(set(names) - {*FORM_FIELDS, FORM_FILE})
    if unknown:
        raise Unprocessable(
            f"unknown form field(s) {', '.join(map(repr, unknown))}; a snapshot has the fields"
            f" {', '.join(FORM_FIELDS)} and the file {FORM_FILE} (protocol.md), nothing else",
            errors=[{"loc": ["body", name], "msg": "unknown form field"} for name in unknown],
        )
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise Unprocessable(
            f"form field(s) {', '.join(map(repr, repeated))} sent more than once; send each once",
            errors=[{"loc": ["body", name], "msg": "repeated form field"} for name in repeated],
        )


def _field_error(msg: str) -> list[dict[str, object]]:
    return [{"loc": ["body", "image"], "msg": msg}]


def check_image(data: bytes, *, max_bytes: int, max_pixels: int) -> CheckedImage:
    """Check an uploaded image before anything is stored.

    The pixel count is read from the header first, so a decompression bomb is refused without
    the image ever being allocated; then the whole file is decoded to catch truncation.
    """
    if not data:
        raise Unprocessable("the image file is empty", errors=_field_error("empty file"))
    if len(data) > max_bytes:
        raise PayloadTooLarge(f"the image has {len(data)} bytes; the limit is {max_bytes}")
    declared = _declared_size(data)
    if declared is not None and declared[0] * declared[1] > max_pixels:
        # Before PIL: its own bomb check refuses without saying the size.
        raise PayloadTooLarge(
            f"the image is {declared[0]}×{declared[1]} pixels; the limit is {max_pixels} pixels"
        )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            image = Image.open(io.BytesIO(data))
            kind = FORMATS.get(image.format or "")
            if kind is None:
                raise Unprocessable(
                    f"the file is {image.format or 'not an image'}; send a JPEG or PNG",
                    errors=_field_error("not JPEG or PNG"),
                )
            width, height = image.size
            if width * height > max_pixels:
                raise PayloadTooLarge(
                    f"the image is {width}×{height} pixels; the limit is {max_pixels} pixels"
                )
            image.load()
    except (Image.DecompressionBombError, Image.DecompressionBombWarning):
        raise PayloadTooLarge(
            f"the image header declares more than {max_pixels} pixels; send a smaller image"
        ) from None
    except UnidentifiedImageError:
        raise Unprocessable(
            "the file is not a readable JPEG or PNG image", errors=_field_error("not an image")
        ) from None
    except (OSError, SyntaxError, ValueError) as exc:
        raise _damaged(str(exc)) from None
    if kind[0] == "image/jpeg":
        _check_jpeg_data(data)
    elif _PNG_END not in data[-4096:]:
        # PIL decodes a PNG cut after its last pixel data; libpng, which the tail check
        # decodes with, refuses it, so it was stored and then never judged.
        raise _damaged("the PNG has no end chunk")
    if min(width, height) < MIN_SIDE:
        raise Unprocessable(
            f"the image is {width}×{height} pixels; a snapshot must be at least"
            f" {MIN_SIDE}×{MIN_SIDE} for the tail check to judge it",
            errors=_field_error("image too small"),
        )
    return CheckedImage(hashlib.sha256(data).hexdigest(), kind[0], kind[1], width, height)


def _declared_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) a PNG's or JPEG's header declares, None for any other file (or a
    header too damaged to say): read without decoding, a bomb's size costs nothing."""
    if data.startswith(b"\x89PNG\r\n\x1a\n") and data[12:16] == b"IHDR":
        return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data.startswith(b"\xff\xd8"):
        try:
            height, width = simplejpeg.decode_jpeg_header(data)[:2]
        except ValueError:
            return None
        return int(width), int(height)
    return None


def _damaged(why: str) -> Unprocessable:
    return Unprocessable(
        f"the image is damaged or truncated ({why}); send the whole file",
        errors=_field_error("damaged or truncated image"),
    )


# A PNG ends with its IEND chunk: the type and the chunk's fixed CRC.
_PNG_END = b"IEND\xaeB`\x82"

# The one warning of libjpeg that loses nothing: padding after the last scan, before the end.
_PADDING = "extraneous bytes before marker 0xd9"


def _check_jpeg_data(data: bytes) -> None:
    """Refuse a JPEG whose compressed data ends early or is corrupt.

    libjpeg only warns when a scan's data runs out and fills the rest of the picture with
    flat grey (PIL and OpenCV decode it without a word): a JPEG cut short and given its end
    marker back, or whose header claims more rows than it holds, was judged ``present`` on
    its upper part and freed a section (an independent trial). libjpeg-turbo's strict mode
    makes every warning an error; decoding at an eighth of the size still reads every bit
    of the compressed data, at a small part of a full decode's cost.
    """
    try:
        colourspace = simplejpeg.decode_jpeg_header(data)[2]
        simplejpeg.decode_jpeg(
            data,
            colorspace="CMYK" if colourspace in ("CMYK", "YCCK") else "GRAY",
            min_factor=8,
            strict=True,
        )
    except ValueError as exc:
        if _PADDING not in str(exc):
            raise _damaged(str(exc)) from None


def image_path(image_dir: Path, sha256: str, suffix: str) -> Path:
    return image_dir / sha256[:2] / f"{sha256}{suffix}"


def stored_image(image_dir: Path, sha256: str, content_type: str) -> Path:
    """Where an accepted upload of ``content_type`` with this hash was stored."""
    return image_path(image_dir, sha256, SUFFIXES[content_type])


@contextmanager
def image_store_lock(image_dir: Path, *, exclusive: bool) -> Iterator[None]:
    """Hold ``fcntl.flock`` on the image folder itself: shared while an upload stores its
    image (uploads never wait for each other), exclusive while ``depot images prune``
    re-checks and removes one file.

    Why no accepted upload can lose its image. An upload refreshes its file's mtime (or
    writes it anew) under the shared lock, then commits its event: a few seconds later
    (detection, one transaction), far within the prune's minimum age of 600 s. The prune
    fixes its cutoff (now − age) *before* it reads which images the database references,
    and removes a file only if, under the exclusive lock, its mtime is still before that
    cutoff. A file so removed was last touched before cutoff, so any upload that touched it
    committed before the prune began reading, and the prune saw that reference and kept the
    file; an upload touching it after the removal finds no file and writes it again.

    The folder is locked rather than a lock file in it: the store holds images only, and
    the backup check (``deploy/restore-test.sh``) counts every file in it as an image.
    Each call opens its own descriptor, so threads of one process lock as processes do.
    """
    image_dir.mkdir(parents=True, exist_ok=True)
    descriptor = os.open(image_dir, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        yield
    finally:
        os.close(descriptor)  # releases the lock


def store_image(image_dir: Path, checked: CheckedImage, data: bytes) -> Path:
    """Write once under its SHA-256; a crash never leaves a half-written file under that name.

    An image already there (an orphan of a refused or interrupted upload, perhaps) has its
    mtime refreshed instead, under the lock: the prune then counts it as recent until this
    upload's event has committed (:func:`image_store_lock` says why that is enough).
    """
    path = image_path(image_dir, checked.sha256, checked.suffix)
    with image_store_lock(image_dir, exclusive=False):
        try:
            os.utime(path)
            return path
        except (FileNotFoundError, PermissionError):
            # Not there (or removed by hand meanwhile), or someone else's file that cannot
            # be touched: a file of our own replaces it, just as fresh.
            pass
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_new(path, data)
    return path


def _write_new(path: Path, data: bytes) -> None:
    # A name of its own per call: threads storing the same image must not share a temporary file.
    descriptor, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    try:
        with os.fdopen(descriptor, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def load_bgr(path: Path) -> NDArray[np.uint8]:
    """Decode a stored image to an (H, W, 3) uint8 BGR array.

    An RGB image is not converted (``convert`` would copy it once more) and its channels are
    swapped by OpenCV: the same array as converting and reversing, in half the time.
    """
    with Image.open(path) as image:
        image.load()
        rgb = np.asarray(image if image.mode == "RGB" else image.convert("RGB"))
    return np.asarray(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), dtype=np.uint8)
