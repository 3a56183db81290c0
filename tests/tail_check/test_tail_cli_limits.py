"""The tail-check CLI refuses an image whose header declares more pixels than the service
accepts, before decoding it: a PNG of a few hundred bytes can declare 30000x30000 pixels,
and the decoder then allocates 2.7 GB for it (the service refuses the same file with 413,
``DEPOT_MAX_IMAGE_PIXELS``, from the header alone). It reads no more bytes than the service
takes and refuses what the service refuses (formats, a JPEG cut short), through the
service's own check (an independent hostile-input trial)."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray
from PIL import Image

import service.commands._image_files as image_files
import service.commands.tail_check as commands
from tests.tail_check.tailkit import plain_disc_scene, run_tail_command

_run = run_tail_command


@pytest.fixture(scope="module")
def scene() -> NDArray[np.uint8]:
    return plain_disc_scene()[0]


def _png_declaring(width: int, height: int) -> bytes:
    """A PNG whose header declares ``width`` x ``height`` RGB pixels, with one row of data."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(kind + body) & 0xFFFFFFFF
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    row = zlib.compress(b"\0" * (1 + 3 * width))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", row) + chunk(b"IEND", b"")


@pytest.mark.parametrize("command", [["tail-check"], ["calibrate", "--disc", "10,10"]])
def test_an_image_declaring_too_many_pixels_is_refused_before_decoding(
    command: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def never(*_: object, **__: object) -> object:
        raise AssertionError("the bomb was handed to the decoder")

    monkeypatch.setattr(image_files, "decode_snapshot", never)
    monkeypatch.setattr(commands, "detect_snapshot", never)
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(_png_declaring(30_000, 30_000))
    assert run_tail_command([command[0], str(bomb), *command[1:]]) == 2
    err = capsys.readouterr().err
    assert "30000×30000 pixels" in err and "40000000" in err and "DEPOT_MAX_IMAGE_PIXELS" in err


def test_the_limit_is_the_services_setting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from core.settings import get_settings

    monkeypatch.setenv("DEPOT_MAX_IMAGE_PIXELS", "1000")
    get_settings.cache_clear()
    try:
        image = tmp_path / "small.png"
        image.write_bytes(_png_declaring(40, 30))
        assert run_tail_command(["tail-check", str(image)]) == 2
        assert "40×30 pixels" in capsys.readouterr().err
    finally:
        get_settings.cache_clear()


@pytest.mark.parametrize(
    ("fmt", "said"), [("BMP", "BMP"), ("GIF", "GIF"), ("WEBP", "WEBP"), ("TIFF", "TIFF")]
)
def test_tail_check_refuses_what_the_service_refuses(
    scene: NDArray[np.uint8],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    fmt: str,
    said: str,
) -> None:
    """The CLI judged BMP, GIF, WebP and TIFF files (``present`` on a disc) that the service
    refuses with 422: the CLI says what the service would (an independent trial)."""
    path = tmp_path / "tail.jpg"
    Image.fromarray(cv2.cvtColor(scene, cv2.COLOR_BGR2RGB)).save(path, format=fmt)
    assert _run(["tail-check", str(path), "--json"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"depot: cannot read image {str(path)!r} (the file is {said}"), err


def test_tail_check_refuses_a_jpeg_cut_short_and_given_its_end_back(
    scene: NDArray[np.uint8], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Cut at 80 % and given its end marker, the JPEG decoded with its lower part grey and
    was judged ``present`` by the CLI and the service alike (an independent trial)."""
    ok, encoded = cv2.imencode(".jpg", scene, [cv2.IMWRITE_JPEG_QUALITY, 92])
    assert ok
    data = encoded.tobytes()
    path = tmp_path / "cut.jpg"
    path.write_bytes(data[: int(len(data) * 0.8)] + b"\xff\xd9")
    assert _run(["tail-check", str(path), "--json"]) == 2
    err = capsys.readouterr().err
    assert "the image is damaged or truncated (Corrupt JPEG data" in err, err


@pytest.mark.parametrize("name", ["sparse", "endless"])
def test_tail_check_never_reads_more_than_the_service_takes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    """A 3 GB file raised an OpenCV traceback and ``/dev/zero`` was read until memory ran
    out: the CLI reads at most the service's byte limit and names it."""
    if name == "sparse":
        path = str(tmp_path / "big.jpg")
        with open(path, "wb") as handle:
            handle.truncate(3 * 1024**3)
    else:
        path = "/dev/zero"
    assert _run(["tail-check", path, "--json"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"depot: image {path!r} has more than 10485760 bytes"), err
    assert "DEPOT_MAX_IMAGE_BYTES" in err
