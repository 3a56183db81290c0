"""Magnetic wheel marks: writing, reading and decoding (spec §1–2; thesis 002, chapter 2).

- :func:`simulate_marking` — the writing algorithm between wheel detectors W1/W2
  (implemented in :mod:`identification.marking`).
- :class:`ReadingSection` — the reading-section state machine fed with sensor edges
  (implemented in :mod:`identification.reading_section`).
- :func:`smooth_baseline` — ``a0`` of the five-point quadratic least-squares fit.
- :func:`decode_passage` — ADC codes of one passage (protocol ``wheel_marks``) to the car's
  code, layouts ``duplicate`` and ``distribute``, with the reason, the readable axles and the
  decision margin.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from identification._crc import crc8, int_to_bytes
from identification.marking import MarkingResult, simulate_marking
from identification.reading_section import ReadingSection, WheelReading
from identification.rules import RULES, IdentificationRules

__all__ = [
    "A0_WEIGHTS",
    "DEFAULT_NOISE_FLOOR",
    "MarkingResult",
    "ReadingSection",
    "WheelDecode",
    "WheelReading",
    "decode_passage",
    "frozen_zero",
    "simulate_marking",
    "smooth_baseline",
]

# ---------------------------------------------------------------------------------------------
# 3. Baseline smoothing and decoding
# ---------------------------------------------------------------------------------------------

#: a0 of the least-squares quadratic through five equally spaced samples (t = -2..2).
A0_WEIGHTS = np.array([-3.0, 12.0, 17.0, 12.0, -3.0]) / 35.0

#: Default noise floor of the polarity threshold, in ADC codes (12-bit reader, zero ≈ 2048).
DEFAULT_NOISE_FLOOR = 30.0


def smooth_baseline(samples: Sequence[float]) -> float:
    """``a0`` of the last five samples: ``(-3·y₋₂ + 12·y₋₁ + 17·y₀ + 12·y₁ - 3·y₂) / 35``.

    The five-point least-squares quadratic filter of eq. 2.1–2.10 (RMS of a0 ≈ 0.697·σ for
    independent noise of deviation σ).
    """
    if len(samples) < 5:
        raise ValueError("smooth_baseline needs at least five samples")
    y = np.asarray(samples[-5:], dtype=float)
    return float(A0_WEIGHTS @ y)


def frozen_zero(baseline: Sequence[float], *, noise_floor: float = DEFAULT_NOISE_FLOOR) -> float:
    """The zero level frozen at car entry: impulse rejection, then :func:`smooth_baseline`.

    The five-point filter alone passes 49 % of a one-sample impulse at its centre, so a strong
    impulse just before entry would still shift the zero. Samples of the last five that lie
    further than ``max(4·σ̂, noise_floor)`` from the median of the last (up to) nine samples
    (σ̂ from the median absolute deviation) are replaced by that median first.
    """
    if len(baseline) < 5:
        raise ValueError("the baseline needs at least five samples")
    ref = np.asarray(baseline[-9:], dtype=float)
    med = float(np.median(ref))
    sigma = 1.4826 * float(np.median(np.abs(ref - med)))
    limit = max(4.0 * sigma, noise_floor)
    y = np.asarray(baseline[-5:], dtype=float)
    y = np.where(np.abs(y - med) > limit, med, y)
    return float(A0_WEIGHTS @ y)


@dataclass(frozen=True)
class WheelDecode:
    """Result of :func:`decode_passage`.

    Attributes
    ----------
    code : int or None
        The car's code, None when it cannot be decided.
    reason : str
        ``"ok"``, or why there is no code (erasures, no majority, CRC, bad payload).
    readable_axles : int
        Axles whose every mark zone was read clearly (no erasure).
    margin : float or None
        The weakest decided bit's value relative to the threshold θ, minus one (0: on the
        threshold, 1: twice θ); for ``duplicate`` a bit's value is the median over the axles.
    zero : float or None
        The frozen zero level (ADC codes).
    threshold : float or None
        θ (ADC codes from the zero).
    bits : list of int or None
        The word in the car's own order, MSB first; None marks an undecided bit.
    """

    code: int | None
    reason: str
    readable_axles: int
    margin: float | None
    zero: float | None = None
    threshold: float | None = None
    bits: list[int | None] = field(default_factory=list)


def _no_code(reason: str, **kw: Any) -> WheelDecode:
    readable = int(kw.pop("readable_axles", 0))
    return WheelDecode(code=None, reason=reason, readable_axles=readable, margin=None, **kw)


def _outside_range(values: Sequence[float], lo: int, hi: int) -> int | None:
    """Index of the first value outside [lo, hi] (NaN included), else None. Pure Python, so an
    integer too large for a float is reported rather than raising."""
    for i, x in enumerate(values):
        if not lo <= x <= hi:
            return i
    return None


def _adc_problem(
    baseline: Sequence[float], axles: Sequence[Sequence[float]], rules: IdentificationRules
) -> str | None:
    lo, hi = rules.adc_min, rules.adc_max
    where: str | None = None
    if (i := _outside_range(baseline, lo, hi)) is not None:
        where, value = f"baseline sample {i + 1}", baseline[i]
    for k, zones in enumerate(axles, 1):
        if where is None and (i := _outside_range(zones, lo, hi)) is not None:
            where, value = f"axle {k} zone {i + 1}", zones[i]
    if where is None:
        return None
    try:
        shown = f"{float(value):.6g}"
    except OverflowError:
        shown = "(an integer too large for any ADC)"
    return f"ADC code {shown} at {where} is outside the reader's range {lo}–{hi}"


def _payload_problem(
    baseline: Sequence[float],
    axles: Sequence[Sequence[float]],
    b: int,
    expected: int | None,
    rules: IdentificationRules,
) -> str | None:
    if not axles:
        return "no axles read"
    if expected is not None and len(axles) != expected:
        return f"{len(axles)} axles read, {expected} expected"
    for k, zones in enumerate(axles, 1):
        if len(zones) != b:
            return f"axle {k} has {len(zones)} mark zones, {b} expected"
    if len(baseline) < 5:
        return f"baseline has {len(baseline)} samples, at least 5 needed"
    return _adc_problem(baseline, axles, rules)


def _duplicate(
    v: npt.NDArray[np.float64], theta: float, need_agree: int, info: dict[str, Any]
) -> WheelDecode:
    """Every axle carries the whole code: per bit, the strict majority of the axles readable
    at that bit, of which there must be at least half the axles, and at least ``need_agree``
    readable axles agreeing (one axle is never checked by another)."""
    n, b = v.shape
    if n < need_agree:
        return _no_code(f"{n} axle(s) read; {need_agree} agreeing axles needed for a code", **info)
    n1 = np.count_nonzero(v >= theta, axis=0)
    n0 = np.count_nonzero(v <= -theta, axis=0)
    need = (n + 1) // 2
    bits: list[int | None] = []
    problems: list[str] = []
    for i in range(b):
        ones, zeros = int(n1[i]), int(n0[i])
        if ones == zeros and ones > 0:
            problems.append(f"bit {i}: no majority ({ones} vs {zeros})")
        elif ones + zeros < need or max(ones, zeros) < need_agree:
            problems.append(
                f"bit {i}: erased on {n - ones - zeros} of {n} axles,"
                f" {max(ones, zeros)} agree; {need_agree} agreeing axles needed"
            )
        else:
            bits.append(int(ones > zeros))
            continue
        bits.append(None)
    if problems:
        more = "; …" if len(problems) > 3 else ""
        return _no_code("; ".join(problems[:3]) + more, bits=bits, **info)
    sign = np.where(np.asarray(bits) == 1, 1.0, -1.0)
    margin = float(np.median(v * sign, axis=0).min() / theta - 1.0)
    code = int("".join(str(x) for x in bits), 2)
    return WheelDecode(code=code, reason="ok", margin=margin, bits=bits, **info)


def _distribute(v: npt.NDArray[np.float64], theta: float, info: dict[str, Any]) -> WheelDecode:
    """Axle k carries bits [(k-1)·B, k·B) of one word: the code, then its CRC-8."""
    total = v.size
    if total <= 8:
        return _no_code(
            f"distribute layout needs more than 8 bits, the passage has {total}", **info
        )
    word = v.reshape(-1)
    bits: list[int | None] = [
        1 if x >= theta else 0 if x <= -theta else None for x in word.tolist()
    ]
    erased = [i for i, x in enumerate(bits) if x is None]
    if erased:
        shown = ", ".join(map(str, erased[:6])) + (", …" if len(erased) > 6 else "")
        return _no_code(f"{len(erased)} erased bits (word positions {shown})", bits=bits, **info)
    value = int("".join(str(x) for x in bits), 2)
    code, crc = value >> 8, value & 0xFF
    if crc8(int_to_bytes(code, total - 8)) != crc:
        return _no_code("CRC mismatch", bits=bits, **info)
    margin = float(np.abs(word).min() / theta - 1.0)
    return WheelDecode(code=code, reason="ok", margin=margin, bits=bits, **info)


def decode_passage(
    baseline: Sequence[float],
    axles: Sequence[Sequence[float]],
    *,
    direction: int,
    bits_per_axle: int | None = None,
    layout: Literal["duplicate", "distribute"] = "duplicate",
    noise_floor: float = DEFAULT_NOISE_FLOOR,
    threshold_fraction: float = 0.5,
    axles_expected: int | None = None,
    rules: IdentificationRules = RULES,
) -> WheelDecode:
    """Decode one ``wheel_marks`` passage (spec §2, decoding steps 1–5).

    1. zero = :func:`frozen_zero` of the baseline (impulse rejection, then ``a0`` of the last
       five samples);
    2. ``v = code − zero``; ``v ≥ +θ`` → 1, ``v ≤ −θ`` → 0, else an erasure, with
       θ = max(``noise_floor``, ``threshold_fraction`` × median |v|) adapting to the car's own
       mark strength;
    3. direction 2 reverses the stream (axles and zones): the word in the car's own order;
    0. a payload the reader cannot have produced gives no code: zones per axle other than the
       fleet's B, an ADC code outside ``rules.adc_min…adc_max`` (also NaN, ±inf);
    4. ``duplicate``: each bit is the strict majority of the axles readable there, with at
       least ``rules.min_agreeing_axles`` of them agreeing (one axle never names a car);
       ``distribute``: one N·B-bit word = code (N·B − 8 bits) then CRC-8 (0x07, init 0) of
       the code written big-endian in whole bytes.

    Parameters
    ----------
    baseline : sequence of float, length >= 5
        DS samples (ADC codes) taken while balancing just before the car.
    axles : sequence of sequence of float, shape (N, B)
        Per axle in passing order, one ADC code per mark zone.
    direction : {1, 2}
        Direction of passage.
    bits_per_axle : int, optional
        B; default: the fleet's ``rules.zones_per_axle``. It is never taken from the payload:
        a truncated read (fewer zones) decoded as a shorter code names another car.
    layout : {"duplicate", "distribute"}
    noise_floor : float
        Smallest θ, in ADC codes.
    threshold_fraction : float
        θ as a fraction of the car's median mark strength.
    axles_expected : int, optional
        Reject a passage with another number of axles.
    rules : IdentificationRules
        The fleet's code length, the reader's ADC range and the agreeing axles a ``duplicate``
        bit needs (:data:`identification.rules.RULES` by default).

    Returns
    -------
    WheelDecode
        ``code`` or None with the reason; a payload that cannot be decoded (wrong zone
        count, short baseline) gives None and a reason, not an exception.

    Raises
    ------
    ValueError
        For a direction other than 1 or 2, an unknown layout or ``bits_per_axle`` < 1.
    """
    if layout not in ("duplicate", "distribute"):
        raise ValueError(f"unknown layout {layout!r} (use 'duplicate' or 'distribute')")
    if direction not in (1, 2):
        raise ValueError(f"direction must be 1 or 2, got {direction!r}")
    if bits_per_axle is not None and bits_per_axle < 1:
        raise ValueError(f"bits_per_axle must be >= 1, got {bits_per_axle}")
    b = rules.zones_per_axle if bits_per_axle is None else bits_per_axle
    problem = _payload_problem(baseline, axles, b, axles_expected, rules)
    if problem is not None:
        return _no_code(problem)
    zero = frozen_zero(baseline, noise_floor=noise_floor)
    flat = np.asarray(axles, dtype=np.float64).reshape(-1) - zero
    if direction == 2:
        flat = flat[::-1]  # the car's own order: axle 1 first, most significant bit first
    theta = max(noise_floor, threshold_fraction * float(np.median(np.abs(flat))))
    v = flat.reshape(len(axles), b)
    clear = (v >= theta) | (v <= -theta)
    readable = int(np.count_nonzero(clear.all(axis=1)))
    info: dict[str, Any] = {"zero": zero, "threshold": theta, "readable_axles": readable}
    if layout == "duplicate":
        return _duplicate(v, theta, rules.min_agreeing_axles, info)
    return _distribute(v, theta, info)
