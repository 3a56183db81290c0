"""CRC-8 shared by the wheel-mark ``distribute`` layout and the Manchester-II frame.

Polynomial x^8 + x^2 + x + 1 (0x07), initial value 0x00, no reflection, no final XOR
(the plain "CRC-8/SMBUS" variant; check value of b"123456789" is 0xF4).
"""

from __future__ import annotations

from collections.abc import Iterable


def _make_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x07) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


_TABLE = _make_table()


def crc8(data: Iterable[int]) -> int:
    """CRC-8 (poly 0x07, init 0x00, no reflection) of a sequence of bytes."""
    crc = 0
    for byte in data:
        crc = _TABLE[crc ^ (byte & 0xFF)]
    return crc


def int_to_bytes(value: int, nbits: int) -> bytes:
    """``value`` written big-endian in the whole bytes needed for ``nbits`` bits."""
    return value.to_bytes((nbits + 7) // 8, "big")
