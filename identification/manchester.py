"""Manchester-II (bi-phase) car identification, continuous-emission variant (spec §4).

Line code: every bit has a mid-bit transition. Convention ``"ieee"`` (IEEE 802.3): 0 =
high→low, 1 = low→high; ``"thomas"`` (G. E. Thomas): the opposite.

Frame (ours; the thesis gives none): preamble ``0x55 0x55``, start delimiter ``0xD5``, the car
number as two bytes big-endian, CRC-8 (poly 0x07, init 0x00) of those two bytes; bytes MSB
first; frames repeat back to back.

Receiver (:func:`decode_passage`): glitch filter → run lengths → clock recovery from the run
lengths (the half-bit period is re-estimated from the signal, so a ±5 % clock error is
absorbed, and each transition resynchronises) → half-bit pairing with the phase fixed by the
long runs → bits with erasures at code violations → frame search, CRC, vote across frames.
:func:`recover_bits` is the reusable clock-and-bit stage (also used on real EM4100 traces).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from identification._crc import crc8
from identification.biphase import (
    BitRecovery,
    Convention,
    bits_to_text,
    check_convention,
    recover_bits,
)
from identification.rules import RULES, IdentificationRules

__all__ = [
    "FRAME_BITS",
    "SYNC",
    "BitRecovery",
    "Convention",
    "ManchesterDecode",
    "decode_passage",
    "encode_frame",
    "frame_bits",
    "recover_bits",
]


PREAMBLE = (0x55, 0x55)
START_DELIMITER = 0xD5
SYNC = "".join(f"{b:08b}" for b in (*PREAMBLE, START_DELIMITER))  # 24 bits
FRAME_BITS = 48  # 2 preamble + 1 delimiter + 2 number + 1 CRC bytes


def frame_bits(car_number: int) -> list[int]:
    """The 48 bits of one frame, MSB first."""
    if not 0 <= car_number <= 0xFFFF:
        raise ValueError("car_number must fit in two bytes (0…65535)")
    payload = (car_number >> 8, car_number & 0xFF)
    data = (*PREAMBLE, START_DELIMITER, *payload, crc8(payload))
    return [int(c) for c in "".join(f"{b:08b}" for b in data)]


def encode_frame(car_number: int, *, convention: Convention = "ieee") -> list[int]:
    """One frame as Manchester-II line levels, one level per half-bit (96 levels).

    Repeat each level ``samples_per_bit / 2`` times for a sampled signal.
    """
    check_convention(convention)
    out: list[int] = []
    for bit in frame_bits(car_number):
        second = bit if convention == "ieee" else 1 - bit
        out.extend((1 - second, second))
    return out


@dataclass(frozen=True)
class ManchesterDecode:
    """Result of :func:`decode_passage`.

    Attributes
    ----------
    car_number : int or None
        The strict majority of the CRC-valid frames; when no single frame is valid, the
        bit-wise vote of all repetitions if that frame passes the CRC; else None.
    frames_ok, frames_bad : int
        Frames found by their 24-bit sync whose payload passed / failed the CRC or held
        erasures.
    reason : str
    numbers : list of int
        The number of each CRC-valid frame.
    combined : bool
        The number comes from the bit-wise vote across frames.
    samples_per_bit_estimate : float or None
        The recovered bit period, samples.
    """

    car_number: int | None
    frames_ok: int
    frames_bad: int
    reason: str
    numbers: list[int] = field(default_factory=list)
    combined: bool = False
    samples_per_bit_estimate: float | None = None


_SYNC_B = SYNC.encode()
_SYNC_A = np.frombuffer(_SYNC_B, dtype=np.uint8) - ord("0")


def _payload_number(payload: npt.NDArray[np.int8] | bytes) -> int | None:
    """The car number of 24 payload bits (number, CRC), None on an erasure or a CRC failure."""
    text = payload if isinstance(payload, bytes) else bits_to_text(payload)
    if len(text) != 24 or b"x" in text:
        return None
    number = int(text[:16], 2)
    return number if crc8((number >> 8, number & 0xFF)) == int(text[16:], 2) else None


def _single_frames(text: bytes) -> tuple[list[int], int]:
    """CRC-valid numbers of the frames found by an exact sync, and the count of bad ones."""
    numbers: list[int] = []
    bad = 0
    pos = text.find(_SYNC_B)
    while pos >= 0 and pos + FRAME_BITS <= len(text):
        number = _payload_number(text[pos + 24 : pos + FRAME_BITS])
        if number is None:
            bad += 1
            pos = text.find(_SYNC_B, pos + 1)
        else:
            numbers.append(number)
            pos = text.find(_SYNC_B, pos + FRAME_BITS)  # no sync is searched inside it
    return numbers, bad


def _fill_one_erasure(payload: npt.NDArray[np.int8]) -> int | None:
    """The number of a payload with at most one erased bit: CRC-8 has Hamming distance 4 on
    24 bits, so at most one of the two fillings can pass, and a wrong one would need three
    wrong bits besides."""
    erased = np.flatnonzero(payload < 0)
    if erased.size > 1:
        return None
    if erased.size == 0:
        return _payload_number(payload)
    found = []
    for value in (0, 1):
        trial = payload.copy()
        trial[erased[0]] = value
        number = _payload_number(trial)
        if number is not None:
            found.append(number)
    return found[0] if len(found) == 1 else None


def _combined_frame(bits: npt.NDArray[np.int8], need: int) -> int | None:
    """Bit-wise vote across the repetitions of the frame.

    Every sync window that agrees with all the bits it holds (erasures allowed, at least 16
    bits known) starts a repetition; each of the 48 frame positions is the majority of the
    repetitions' non-erased bits, read in at least ``need`` of them (a bit seen once is one
    read, as a frame seen once is); the voted frame must pass the CRC (one erased bit may be
    filled by it).
    """
    if bits.size < 24:
        return None
    win = np.lib.stride_tricks.sliding_window_view(bits, 24)
    known = (win >= 0).sum(axis=1)
    clean = ~np.any((win >= 0) & (win != _SYNC_A), axis=1) & (known >= 16)
    starts: list[int] = []
    for p in sorted(np.flatnonzero(clean).tolist(), key=lambda q: -int(known[q])):
        if all(abs(p - q) >= FRAME_BITS - 8 for q in starts):
            starts.append(p)
    if not starts:
        return None
    padded = np.concatenate((bits, np.full(FRAME_BITS, -1, np.int8)))
    stack = np.stack([padded[p : p + FRAME_BITS] for p in starts])
    ones = np.count_nonzero(stack == 1, axis=0)
    zeros = np.count_nonzero(stack == 0, axis=0)
    one = (ones > zeros) & (ones >= need)
    zero = (zeros > ones) & (zeros >= need)
    voted = np.where(one, 1, np.where(zero, 0, -1)).astype(np.int8)
    return _fill_one_erasure(voted[24:])


def decode_passage(
    samples: Sequence[int] | npt.NDArray[np.integer],
    *,
    samples_per_bit: float,
    convention: Convention = "ieee",
    rules: IdentificationRules = RULES,
) -> ManchesterDecode:
    """Decode one ``ir_manchester`` passage.

    Parameters
    ----------
    samples : sequence of int or ndarray, shape (n,)
        The received line signal, 0/1.
    samples_per_bit : float
        Nominal samples per bit (>= 2); the true rate may differ by several per cent.
    convention : {"ieee", "thomas"}
    rules : IdentificationRules
        ``min_agreeing_reads``: CRC-valid frames that must agree (or, with fewer, how many
        repetitions must agree on each bit of the voted frame).

    Returns
    -------
    ManchesterDecode
        The car number (strict majority of the CRC-valid frames, read at least
        ``rules.min_agreeing_reads`` times, or else the bit-wise vote across frames) or None
        with the reason.
    """
    rec = recover_bits(samples, samples_per_bit=samples_per_bit, convention=convention)
    numbers, bad = _single_frames(bits_to_text(rec.bits))
    spb = 2.0 * rec.half_bit if rec.bits.size else None
    need = rules.min_agreeing_reads
    best, count = Counter(numbers).most_common(1)[0] if numbers else (None, 0)
    if numbers and 2 * count <= len(numbers):
        reason = "frames disagree: no strict majority"
        return ManchesterDecode(None, len(numbers), bad, reason, numbers, False, spb)
    if count >= need:
        return ManchesterDecode(best, len(numbers), bad, "ok", numbers, False, spb)
    # Fewer valid frames than reads needed: the repetitions together, bit by bit, may still
    # show the number read often enough (a bad frame's other bits agree with the good one).
    voted = _combined_frame(rec.bits, need)
    if voted is not None and best in (None, voted):
        reason = "ok (bit-wise vote across frames)"
        return ManchesterDecode(voted, len(numbers), bad, reason, numbers, True, spb)
    if numbers:
        reason = f"only {count} valid frame(s) of {best}; {need} agreeing reads needed"
    else:
        reason = "no valid frame" if bad else "no frame found"
    return ManchesterDecode(None, len(numbers), bad, reason, numbers, False, spb)
