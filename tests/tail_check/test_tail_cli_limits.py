"""The tail-check CLI refuses an image whose header declares more pixels than the service
accepts, before decoding it: a PNG of a few hundred bytes can declare 30000x30000 pixels,
and the decoder then allocates 2.7 GB for it (the service refuses the same file with 413,
``DEPOT_MAX_IMAGE_PIXELS``, from the header alone)."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import pytest

import service.commands._image_files as image_files
import service.commands.tail_check as commands
from tests.tail_check.tailkit import run_tail_command


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
