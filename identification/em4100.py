"""EM4100/EM4102 RFID tags: a real-signal check of the Manchester clock recovery.

The proxmark3 traces in ``shared/data/real/manchester_em4102/`` are analogue (one signed 8-bit
ADC sample per 125 kHz carrier cycle), Manchester coded at RF/64 (64 samples per bit) with
the G. E. Thomas convention (high→low = 1, our ``"thomas"``). Their frame differs from ours:
9 header ones, 10 rows of 4 data bits plus an even row parity, 4 column parity bits, a stop
bit 0 (64 bits; 40-bit ID = 10 hex digits).

:func:`decode_trace` binarises the analogue signal (moving average, median threshold), then
uses :func:`identification.manchester.recover_bits` — the very clock recovery and bit decoding
of our own decoder — and searches EM4100 frames with full parity checks.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from identification.biphase import Convention, bits_to_text, recover_bits

__all__ = ["EM4100Decode", "binarise", "decode_trace", "load_pm3", "parse_frame"]

HEADER = b"1" * 9
FRAME_LEN = 64


def load_pm3(path: str | Path) -> npt.NDArray[np.float64]:
    """A proxmark3 ``.pm3`` trace: one integer sample per line."""
    return np.loadtxt(path, dtype=np.float64).reshape(-1)


def binarise(signal: npt.NDArray[np.float64], *, smoothing: int = 1) -> npt.NDArray[np.int8]:
    """Moving average over ``smoothing`` samples, then threshold at the median."""
    y = signal
    if smoothing > 1:
        y = np.convolve(signal, np.ones(smoothing) / smoothing, mode="same")
    return (y > np.median(y)).astype(np.int8)


def parse_frame(bits: bytes) -> str | None:
    """The 10-hex-digit ID of one 64-bit EM4100 frame (``b"0"``/``b"1"``), or None."""
    if len(bits) != FRAME_LEN or not bits.startswith(HEADER) or bits[63:64] != b"0":
        return None
    if b"x" in bits:
        return None
    b = [c - 48 for c in bits]
    nibbles = []
    for row in range(10):
        r = b[9 + 5 * row : 14 + 5 * row]
        if sum(r) % 2:
            return None  # row parity (even)
        nibbles.append(r[:4])
    for col in range(4):
        if (sum(n[col] for n in nibbles) + b[59 + col]) % 2:
            return None  # column parity (even)
    return "".join(f"{int(''.join(map(str, n)), 2):x}" for n in nibbles)


@dataclass(frozen=True)
class EM4100Decode:
    tag_id: str | None
    frames_ok: int
    smoothing: int | None = None
    convention: Convention | None = None
    samples_per_bit_estimate: float | None = None
    ids: list[str] = field(default_factory=list)


def _frames(text: bytes) -> list[str]:
    out: list[str] = []
    pos = text.find(HEADER)
    while pos >= 0:
        if pos == 0 or text[pos - 1 : pos] != b"1":
            tag = parse_frame(text[pos : pos + FRAME_LEN])
            if tag is not None:
                out.append(tag)
                pos = text.find(HEADER, pos + FRAME_LEN)
                continue
        pos = text.find(HEADER, pos + 1)
    return out


def decode_trace(
    signal: npt.NDArray[np.float64],
    *,
    samples_per_bit: float = 64,
    smoothings: Sequence[int] = (1, 8, 16),
    conventions: Sequence[Convention] = ("thomas", "ieee"),
) -> EM4100Decode:
    """Decode an analogue EM4100 trace. Every smoothing × convention is tried; the one giving
    the most parity-valid frames wins, and the ID is the strict majority of its frames."""
    best: EM4100Decode = EM4100Decode(None, 0)
    for smoothing in smoothings:
        x = binarise(signal, smoothing=smoothing)
        for convention in conventions:
            rec = recover_bits(x, samples_per_bit=samples_per_bit, convention=convention)
            ids = _frames(bits_to_text(rec.bits))
            if len(ids) <= best.frames_ok:
                continue
            tag, count = Counter(ids).most_common(1)[0]
            if 2 * count > len(ids):
                best = EM4100Decode(tag, len(ids), smoothing, convention, 2 * rec.half_bit, ids)
    return best
