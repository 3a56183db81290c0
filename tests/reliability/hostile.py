"""Hostile request bodies for the device and setup endpoints (built in memory, no fixtures)."""

from __future__ import annotations

import io
import json
import struct
import zlib
from collections.abc import Callable, Iterator
from typing import Any

from PIL import Image

EVENT = {"event_id": "h-1", "occurred_at": "2026-11-23T10:00:00Z", "kind": "heartbeat"}


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png_bomb(side: int = 9000) -> bytes:
    """A valid greyscale PNG of side×side zero pixels (81 MP), a few dozen kB compressed."""
    packer = zlib.compressobj(9)
    row = b"\x00" * (side + 1)
    body = b"".join(packer.compress(row) for _ in range(side)) + packer.flush()
    header = struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", body)
        + _chunk(b"IEND", b"")
    )


def png_header_only(width: int = 65535, height: int = 65535) -> bytes:
    """A PNG header declaring a huge image, with no pixel data at all."""
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", header) + _chunk(b"IEND", b"")


_shade = [0]


def small_image(fmt: str, size: tuple[int, int] = (64, 48)) -> bytes:
    """A small image of a colour never used before, so its content address is new."""
    _shade[0] += 1
    buffer = io.BytesIO()
    Image.new("RGB", size, (200, 30, 30)).save(buffer, format=fmt)
    data = buffer.getvalue()
    if fmt == "JPEG":  # a comment segment makes the file unique; the picture is the same
        tag = f"shot {_shade[0]}".encode()
        data = data[:2] + b"\xff\xfe" + (len(tag) + 2).to_bytes(2, "big") + tag + data[2:]
    return data


def jpeg_huge_dimensions() -> bytes:
    """A real small JPEG whose frame header is patched to claim 60000×60000 pixels."""
    data = bytearray(small_image("JPEG"))
    sof = data.find(b"\xff\xc0")
    data[sof + 5 : sof + 9] = struct.pack(">HH", 60000, 60000)
    return bytes(data)


def deep_json(depth: int) -> bytes:
    return b"[" * depth + b"]" * depth


def big_json(size: int) -> bytes:
    """One syntactically valid event padded with a long list to ``size`` bytes."""
    reads = ",".join(["117"] * (size // 4))
    return (
        '{"event_id":"big","occurred_at":"2026-11-23T10:00:00Z","kind":"ir_id",'
        f'"section":"AB","reads":[{reads}]}}'
    ).encode()


def chunks(data: bytes, size: int = 1 << 20) -> Iterator[bytes]:
    """Streamed without Content-Length (chunked transfer): the limit must hold while reading."""
    for start in range(0, len(data), size):
        yield data[start : start + size]


def over_long_batch() -> bytes:
    events = [{**EVENT, "event_id": f"b-{n}"} for n in range(1001)]
    return json.dumps({"events": events}).encode()


RequestSpec = Callable[[], dict[str, Any]]
JSON_HEADERS = {"Content-Type": "application/json"}

# name → (method, path, request kwargs builder, expected status)
EVENT_ATTACKS: dict[str, tuple[RequestSpec, int]] = {
    "text/plain body": (
        lambda: {"content": json.dumps(EVENT), "headers": {"Content-Type": "text/plain"}},
        415,
    ),
    "no content type": (lambda: {"content": json.dumps(EVENT).encode()}, 415),
    "form posing as json": (lambda: {"data": {"event_id": "x"}}, 415),
    "10 MB JSON": (lambda: {"content": big_json(10 << 20), "headers": JSON_HEADERS}, 413),
    "10 MB JSON chunked": (
        lambda: {"content": chunks(big_json(10 << 20)), "headers": JSON_HEADERS},
        413,
    ),
    "JSON nested 100000 deep": (
        lambda: {"content": deep_json(100_000), "headers": JSON_HEADERS},
        422,
    ),
    "event nested 500 deep": (
        lambda: {
            "content": json.dumps({**EVENT, "x": json.loads(deep_json(500))}),
            "headers": JSON_HEADERS,
        },
        422,
    ),
    "not JSON": (lambda: {"content": b"\xff\xfe{", "headers": JSON_HEADERS}, 422),
    "NaN in JSON": (
        lambda: {
            "content": b'{"event_id":"n","occurred_at":"2026-11-23T10:00:00Z","kind":"axle_count",'
            b'"section":"AB","axles":NaN}',
            "headers": JSON_HEADERS,
        },
        422,
    ),
    "1001 events in a batch": (
        lambda: {"content": over_long_batch(), "headers": JSON_HEADERS},
        422,
    ),
    "event_id with spaces (SQL)": (
        lambda: {"json": {**EVENT, "event_id": "1'; DROP TABLE raw_events; --"}},
        422,
    ),
    "event_id with newline": (lambda: {"json": {**EVENT, "event_id": "a\r\nX-Admin: 1"}}, 422),
    "event_id too long": (lambda: {"json": {**EVENT, "event_id": "e" * 65}}, 422),
    "event_id non-ASCII": (lambda: {"json": {**EVENT, "event_id": "подія-1"}}, 422),
    "naive time": (lambda: {"json": {**EVENT, "occurred_at": "2026-11-23T10:00:00"}}, 422),
    "unknown kind": (lambda: {"json": {**EVENT, "kind": "__proto__"}}, 422),
    "extra field": (lambda: {"json": {**EVENT, "admin": True}}, 422),
    "array body": (lambda: {"json": [EVENT]}, 422),
}

FORM = {"event_id": "snap-h", "occurred_at": "2026-11-23T10:00:00Z", "section": "AB"}


def _upload(data: bytes, name: str = "tail.jpg", ctype: str = "image/jpeg") -> dict[str, Any]:
    return {"data": FORM, "files": {"image": (name, data, ctype)}}


SNAPSHOT_ATTACKS: dict[str, tuple[RequestSpec, int]] = {
    "PNG decompression bomb (81 MP)": (lambda: _upload(png_bomb(), "t.png", "image/png"), 413),
    "PNG header claiming 65535x65535": (
        lambda: _upload(png_header_only(), "t.png", "image/png"),
        413,
    ),
    "JPEG claiming 60000x60000": (lambda: _upload(jpeg_huge_dimensions()), 413),
    "file over 10 MB": (lambda: _upload(small_image("JPEG") + b"\0" * (10 << 20)), 413),
    "GIF": (lambda: _upload(small_image("GIF"), "t.gif", "image/gif"), 422),
    "BMP named .jpg": (lambda: _upload(small_image("BMP")), 422),
    "text named .jpg": (lambda: _upload(b"<?php system($_GET['c']); ?>"), 422),
    "truncated JPEG": (lambda: _upload(small_image("JPEG")[:300]), 422),
    "empty file": (lambda: _upload(b""), 422),
    "no image field": (lambda: {"data": FORM, "files": {"other": ("a", b"x", "text/plain")}}, 422),
    "JSON instead of multipart": (lambda: {"json": FORM}, 415),
    "two image files": (
        lambda: {
            "data": FORM,
            "files": [("image", ("a.jpg", small_image("JPEG"), "image/jpeg"))] * 2,
        },
        400,
    ),
    "event_id with CRLF": (
        lambda: {
            **_upload(small_image("JPEG")),
            "data": {**FORM, "event_id": "a\r\nSet-Cookie: x=1"},
        },
        422,
    ),
    "occurred_at garbage": (
        lambda: {**_upload(small_image("JPEG")), "data": {**FORM, "occurred_at": "'; --"}},
        422,
    ),
    "foreign section": (
        lambda: {**_upload(small_image("JPEG")), "data": {**FORM, "section": "BC"}},
        422,
    ),
}

HOSTILE_IDS = [
    "../../etc/passwd",
    "A/B",
    "..",
    "A'; DROP TABLE stations; --",
    "A%2F..%2F",
    "A\r\nX-Injected: 1",
    "A\x00B",
    "<script>alert(1)</script>",
    "x" * 65,
    "",
]
SETUP_BODIES: dict[str, Callable[[str], dict[str, Any]]] = {
    "/stations": lambda i: {"id": i, "name": "Evil"},
    "/sections": lambda i: {"id": i, "from_station": "A", "to_station": "C"},
    "/devices": lambda i: {"id": i, "station": "A", "kind": "camera"},
    "/cars": lambda i: {"id": i, "axles": 4},
}
