"""EM4100/EM4102 RFID tags: a real-signal check of the Manchester clock recovery.

The proxmark3 traces in ``shared/data/real/manchester_em4102/`` are analogue (one signed 8-bit
ADC sample per 125 kHz carrier cycle), Manchester coded at RF/64 (64 samples per bit) with
the G. E. Thomas convention (high→low = 1, our ``"thomas"``). Their frame differs from ours:
9 header ones, 10 rows of 4 data bits plus an even row parity, 4 column parity bits, a stop
bit 0 (64 bits; 40-bit ID = 10 hex digits).

:func:`decode_trace` binarises the analogue signal (moving average, median threshold), then
uses :func:`identification.manchester.recover_bits` — the very clock recovery and bit decoding
of our own decoder — and searches EM4100 frames with full parity checks.

A frame that passes its parities is not yet an ID (found by the independent trial: the fob's
trace played backwards gives eight parity-valid frames of 3be164c009, its ID being
0400193cbe). An ID is given only when (:func:`decode_trace`):

- every parity-valid frame of the winning reading names the same ID, and all of them sit at
  whole frames (64 bits) from one another (one bit phase);
- the trace runs forward in time. A tag's load modulation reaches the reader through the
  antenna's band-pass: at every edge the signal jumps, then decays back (see the traces).
  :func:`time_arrow` compares the signal's excursion just after the edges with just before;
  played backwards it is reversed. A reversed trace is refused; when the shape is not evident
  (a heavily clipped recording), the ID is given only if the trace read backwards holds no
  parity-valid frame (a reading in both time directions is ambiguous).

Usage (there is no CLI and no API for EM4102: it is a real-signal check of the decoder)::

    from identification.em4100 import decode_trace, load_pm3
    r = decode_trace(load_pm3("shared/data/real/manchester_em4102/lf_EM4102-fob.pm3"))
    r.tag_id, r.frames_ok, r.reason       # ('0400193cbe', 9, 'ok')
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from identification.biphase import Convention, bits_to_text, recover_bits

__all__ = [
    "DEFAULT_TUNING",
    "EM4100Decode",
    "EM4100Tuning",
    "binarise",
    "decode_trace",
    "frame_consensus",
    "load_pm3",
    "parse_frame",
    "time_arrow",
]

HEADER = b"1" * 9
FRAME_LEN = 64


def load_pm3(path: str | Path) -> npt.NDArray[np.float64]:
    """A proxmark3 ``.pm3`` trace: one integer sample per line."""
    return np.loadtxt(path, dtype=np.float64).reshape(-1)


@dataclass(frozen=True)
class EM4100Tuning:
    """The decoder's parameters.

    Attributes
    ----------
    samples_per_bit : float
        Nominal samples per bit (RF/64 at one sample per carrier cycle: 64).
    smoothings : tuple of int
        Moving-average lengths tried before the median threshold.
    conventions : tuple of str
        Manchester conventions tried (EM4100 is ``"thomas"``; ``"ieee"`` reads an inverted
        signal).
    arrow_window_bits : float
        Window after and before each edge, in bits, over which :func:`time_arrow` compares
        the signal's excursion from its median (a quarter bit: the decay after a jump).
    arrow_margin : float
        ``|time_arrow|`` (a log ratio) below this: the time direction is not evident. The six
        real traces give +0.46…+1.73 forward (−0.46…−1.73 reversed); clipped to ±10 ADC
        codes around the median, +0.03…+0.30.
    """

    samples_per_bit: float = 64.0
    smoothings: tuple[int, ...] = (1, 8, 16)
    conventions: tuple[Convention, ...] = ("thomas", "ieee")
    arrow_window_bits: float = 0.25
    arrow_margin: float = 0.1


DEFAULT_TUNING = EM4100Tuning()


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
    """Result of :func:`decode_trace`: ``tag_id`` (10 hex digits) or None with the ``reason``;
    ``frames_ok`` parity-valid frames of the winning reading, their ``ids``, the reading
    (``smoothing``, ``convention``), the recovered clock and the :func:`time_arrow`."""

    tag_id: str | None
    frames_ok: int
    smoothing: int | None = None
    convention: Convention | None = None
    samples_per_bit_estimate: float | None = None
    ids: list[str] = field(default_factory=list)
    reason: str = "no parity-valid EM4100 frame found"
    arrow: float | None = None


def _frames(text: bytes) -> list[tuple[int, str]]:
    """(bit position, ID) of every parity-valid frame in the bit text."""
    out: list[tuple[int, str]] = []
    pos = text.find(HEADER)
    while pos >= 0:
        if pos == 0 or text[pos - 1 : pos] != b"1":
            tag = parse_frame(text[pos : pos + FRAME_LEN])
            if tag is not None:
                out.append((pos, tag))
                pos = text.find(HEADER, pos + FRAME_LEN)
                continue
        pos = text.find(HEADER, pos + 1)
    return out


def _consensus(frames: list[tuple[int, str]]) -> tuple[str | None, str]:
    if not frames:
        return None, "no parity-valid EM4100 frame found"
    ids = sorted({tag for _, tag in frames})
    if len(ids) > 1:
        return None, f"parity-valid frames disagree ({', '.join(ids[:4])})"
    phases = {pos % FRAME_LEN for pos, _ in frames}
    if len(phases) > 1:
        return None, f"frames of {ids[0]} at {len(phases)} different bit phases"
    return ids[0], "ok"


def frame_consensus(text: bytes) -> tuple[str | None, str]:
    """The ID of a bit text (``b"0"``/``b"1"``/``b"x"``): every parity-valid frame must name the
    same ID at the same bit phase (whole frames apart); else None and the reason."""
    return _consensus(_frames(text))


def time_arrow(
    signal: npt.NDArray[np.float64], *, smoothing: int = 1, tuning: EM4100Tuning = DEFAULT_TUNING
) -> float:
    """log(excursion after the edges / excursion before them): > 0 forward in time.

    Edges are the transitions of :func:`binarise`; the excursion is |signal − median| summed
    over ``tuning.arrow_window_bits`` after, and before, every edge. 0 when there are no edges.
    """
    w = max(1, round(tuning.arrow_window_bits * tuning.samples_per_bit))
    edges = np.flatnonzero(np.diff(binarise(signal, smoothing=smoothing))) + 1
    edges = edges[(edges >= w) & (edges + w <= signal.size)]
    c = np.concatenate(([0.0], np.cumsum(np.abs(signal - np.median(signal)))))
    after = float(np.sum(c[edges + w] - c[edges]))
    before = float(np.sum(c[edges] - c[edges - w]))
    if edges.size == 0 or after <= 0 or before <= 0:
        return 0.0
    return float(np.log(after / before))


def _best_reading(signal: npt.NDArray[np.float64], tuning: EM4100Tuning) -> EM4100Decode:
    """The smoothing × convention giving the most parity-valid frames, with its consensus."""
    best = EM4100Decode(None, 0)
    for smoothing in tuning.smoothings:
        x = binarise(signal, smoothing=smoothing)
        for convention in tuning.conventions:
            rec = recover_bits(x, samples_per_bit=tuning.samples_per_bit, convention=convention)
            frames = _frames(bits_to_text(rec.bits))
            if len(frames) > best.frames_ok:
                tag, reason = _consensus(frames)
                ids = [t for _, t in frames]
                spb = 2 * rec.half_bit
                best = EM4100Decode(tag, len(frames), smoothing, convention, spb, ids, reason)
    return best


def _checked(signal: npt.NDArray[np.float64], tuning: EM4100Tuning) -> npt.NDArray[np.float64]:
    x = np.asarray(signal, dtype=np.float64).reshape(-1)
    if x.size == 0:
        raise ValueError("the EM4100 trace is empty: give the reader's ADC samples")
    if not np.all(np.isfinite(x)):
        raise ValueError("the EM4100 trace holds samples that are not finite numbers")
    if not tuning.samples_per_bit >= 2:
        raise ValueError(f"samples_per_bit must be at least 2, got {tuning.samples_per_bit}")
    return x


def decode_trace(
    signal: npt.NDArray[np.float64], *, tuning: EM4100Tuning = DEFAULT_TUNING
) -> EM4100Decode:
    """Decode an analogue EM4100 trace (see the module's description).

    Every smoothing × convention is tried; the one giving the most parity-valid frames wins.
    Its frames must all name one ID at one bit phase, and the trace must run forward in time
    (:func:`time_arrow`), else ``tag_id`` is None and ``reason`` says why.

    Raises
    ------
    ValueError
        For an empty trace or one with non-finite samples.
    """
    x = _checked(signal, tuning)
    best = _best_reading(x, tuning)
    if best.tag_id is None or best.smoothing is None:
        return best
    arrow = time_arrow(x, smoothing=best.smoothing, tuning=tuning)
    reason = "ok"
    if arrow <= -tuning.arrow_margin:
        reason = f"the trace runs backwards in time (time arrow {arrow:+.2f})"
    elif arrow < tuning.arrow_margin and _best_reading(x[::-1], tuning).frames_ok:
        reason = (
            f"frames read in both time directions and the signal's shape does not tell which"
            f" is forward (time arrow {arrow:+.2f})"
        )
    tag = best.tag_id if reason == "ok" else None
    return replace(best, tag_id=tag, reason=reason, arrow=arrow)
