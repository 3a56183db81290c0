"""Bi-phase (Manchester-II) clock recovery and bit decoding of a sampled 0/1 signal.

Used by :mod:`identification.manchester` for our frames and by :mod:`identification.em4100` on
real RFID recordings. Convention ``"ieee"`` (IEEE 802.3): 0 = high→low, 1 = low→high;
``"thomas"`` (G. E. Thomas): the opposite.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

__all__ = ["BitRecovery", "Convention", "bits_to_text", "check_convention", "recover_bits"]

Convention = Literal["ieee", "thomas"]


def check_convention(convention: str) -> None:
    if convention not in ("ieee", "thomas"):
        raise ValueError(f"unknown convention {convention!r} (use 'ieee' or 'thomas')")


@dataclass(frozen=True)
class BitRecovery:
    """Bits recovered from a sampled Manchester signal.

    ``bits``: 0/1, or -1 for an erasure (a code violation, or a break between runs of valid
    code). ``half_bit``: the estimated half-bit period in samples.
    """

    bits: npt.NDArray[np.int8]
    half_bit: float
    violations: int


def _majority_filter(x: npt.NDArray[np.int8], width: int) -> npt.NDArray[np.int8]:
    """Running majority (the median of a binary signal) over an odd ``width``."""
    if width < 3 or x.size < width:
        return x
    c = np.concatenate((np.zeros(1, np.int32), np.cumsum(x, dtype=np.int32)))
    half = width // 2
    s = c[width:] - c[:-width]
    out = x.copy()
    out[half : half + s.size] = s > half
    return out


_EMPTY = np.zeros(0, np.int8)


def _as_binary(samples: Sequence[int] | npt.NDArray[np.integer]) -> npt.NDArray[np.int8]:
    """0/1 samples as an int8 array (fast path for the lists of small ints of a payload)."""
    raw: npt.NDArray[Any]
    if isinstance(samples, list | tuple):
        try:
            raw = np.frombuffer(bytes(samples), dtype=np.uint8)
        except (TypeError, ValueError):
            raw = np.asarray(samples)
    else:
        raw = np.asarray(samples)
    binary: npt.NDArray[np.int8] = (raw != 0).astype(np.int8)
    return binary


def _edges(x: npt.NDArray[np.int8]) -> npt.NDArray[np.intp]:
    """Sample indices at which the level changes."""
    return np.flatnonzero(x[1:] != x[:-1]) + 1


def _merge_glitches(
    x: npt.NDArray[np.int8], h: float, limit: int = 64
) -> tuple[npt.NDArray[np.int8], npt.NDArray[np.intp]]:
    """Flip runs shorter than 0.6 half-bit into their neighbours (which share one level),
    shortest first: a glitch the majority filter left would otherwise split a run into pieces
    that each round to a whole half-bit and shift the rest of the stream. Returns the signal
    and its edges."""
    out = x
    edges = _edges(out)
    for _ in range(limit):
        if edges.size < 2:
            break
        lengths = np.diff(edges)
        k = int(np.argmin(lengths))
        if lengths[k] > 0.6 * h:
            break
        if out is x:
            out = x.copy()
        out[edges[k] : edges[k + 1]] ^= 1
        edges = _edges(out)
    return out, edges


def _runs(
    x: npt.NDArray[np.int8], edges: npt.NDArray[np.intp], h_nom: float
) -> tuple[npt.NDArray[np.int8], npt.NDArray[np.int64], float]:
    """Runs between transitions: level, length in half-bits (valid: 1 or 2) and the
    estimated half-bit period. The recording cuts the first and last run, which only hides
    half-bits before and after it, so they count for the half-bits they hold."""
    bounds = np.concatenate(([0], edges, [x.size]))
    lengths = np.diff(bounds).astype(np.float64)
    inner = lengths[1:-1]
    u0 = np.rint(inner / h_nom)
    ok0 = (u0 == 1) | (u0 == 2)
    h = float(inner[ok0].sum() / u0[ok0].sum()) if ok0.any() else h_nom
    if not 0.75 * h_nom <= h <= 1.25 * h_nom:
        h = h_nom  # no usable clock: keep the nominal one
    units = np.rint(lengths / h).astype(np.int64)
    return x[bounds[:-1]], units, h


def _phases(sym: npt.NDArray[np.int8], long_at: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Per half-bit, the parity at which bits start (-1: unknown).

    Long runs are the anchors: a long run is the second half of one bit and the first half of
    the next. Each half-bit takes the phase of the nearest anchors before and after it within
    its unbroken stretch; where they disagree the clock slipped in between (a glitch made a
    run look longer or shorter) and the half-bits there are unknown.
    """
    n = sym.size
    if long_at.size == 0:
        return np.full(n, -1, np.int64)
    seg = np.cumsum(sym == 2)
    par = (long_at + 1) % 2
    k = np.searchsorted(long_at, np.arange(n), side="right") - 1
    kp = np.maximum(k, 0)
    kn = np.minimum(k + 1, long_at.size - 1)
    prev_ok = (k >= 0) & (seg[long_at[kp]] == seg)
    next_ok = (k + 1 < long_at.size) & (seg[long_at[kn]] == seg)
    pp, pn = par[kp], par[kn]
    both = np.where(pp == pn, pp, -1)
    return np.where(prev_ok & next_ok, both, np.where(prev_ok, pp, np.where(next_ok, pn, -1)))


def recover_bits(
    samples: Sequence[int] | npt.NDArray[np.integer],
    *,
    samples_per_bit: float,
    convention: Convention = "ieee",
    glitch_filter: bool = True,
) -> BitRecovery:
    """Clock recovery and Manchester-II bit decoding of a 0/1 sampled signal.

    1. isolated flipped samples are removed by a running majority over about a sixth of a
       half-bit (at least 3 samples, when a half-bit has 3 samples or more);
    2. runs between transitions are 1 or 2 half-bits long: the half-bit period is estimated
       from the runs the nominal period classifies, then every run is classified again with
       it (every transition resynchronises); other runs are code violations;
    3. the half-bits are paired into bits with the phase set by the long runs
       (:func:`_phases`);
    4. a pair with equal halves is a violation.

    Parameters
    ----------
    samples : sequence of int or ndarray, shape (n,)
        The line signal, 0/1 (any non-zero value counts as 1).
    samples_per_bit : float
        Nominal samples per bit (>= 2).
    convention : {"ieee", "thomas"}

    Returns
    -------
    BitRecovery
        Bits (0/1, -1 for an erasure), the estimated half-bit period (samples) and the number
        of code violations.
    """
    check_convention(convention)
    h_nom = float(samples_per_bit) / 2.0
    if h_nom < 1.0:
        raise ValueError(f"samples_per_bit must be at least 2, got {samples_per_bit}")
    x = _as_binary(samples)
    if glitch_filter and h_nom >= 3:
        x, edges = _merge_glitches(_majority_filter(x, max(3, 2 * int(h_nom // 6) + 1)), h_nom)
    else:
        edges = _edges(x)
    if edges.size < 2:
        return BitRecovery(_EMPTY, h_nom, 0)
    levels, units, h = _runs(x, edges, h_nom)
    valid = (units == 1) | (units == 2)
    reps = np.maximum(units, 1)  # a violation keeps its duration, so later bits stay in place
    sym = np.repeat(np.where(valid, levels, 2).astype(np.int8), reps)
    run_start = np.cumsum(reps) - reps  # half-bit index of each run's first half-bit
    phase = _phases(sym, run_start[units == 2])

    idx = np.arange(sym.size - 1)
    ok = (phase[idx] >= 0) & (idx % 2 == phase[idx]) & (phase[idx + 1] == phase[idx])
    starts = idx[ok & (sym[idx] != 2) & (sym[idx + 1] != 2)]
    first, second = sym[starts], sym[starts + 1]
    bitval = second if convention == "ieee" else first
    bits = np.where(first != second, bitval, -1).astype(np.int8)
    violations = int(np.count_nonzero(bits < 0)) + int(np.count_nonzero(~valid))
    # the bits lost between stretches become erasures, so that frames keep their length
    step = np.diff(starts)
    gaps = np.flatnonzero(step != 2)
    if gaps.size:
        lost = np.maximum(1, np.rint(step[gaps] / 2.0).astype(np.int64) - 1)
        bits = np.insert(bits, np.repeat(gaps + 1, lost), np.int8(-1))
    return BitRecovery(bits, h, violations)


_CHARS = np.frombuffer(b"01x", dtype=np.uint8)


def bits_to_text(bits: npt.NDArray[np.int8]) -> bytes:
    """``0``/``1``/``x`` (erasure) as bytes, for fast pattern search."""
    return _CHARS[np.where(bits < 0, 2, bits)].tobytes()
