"""Signal simulators for tests, benchmarks and the demo — kept apart from the decoders.

Each ``*_passage`` function returns a dict with exactly the payload fields of the matching
protocol event (``ir_pulses``, ``ir_manchester``, ``wheel_marks``), decodable by the decoders
of this package with their default parameters:

- :func:`ir_pulses_passage` — infrared time-pulse transponder and reader (spec §3);
- :func:`manchester_passage` — continuously emitting Manchester-II transponder (spec §4);
- :func:`wheel_mark_passage` — magnetic wheel-mark reader (spec §2);
- :func:`reading_edges` — the same passage as raw reading-section sensor edges;
- :func:`marking_detections` — wheel-detector hits W1/W2 of a car moving (and reversing)
  through the marking station (spec §1).

All randomness comes from the ``rng`` argument (``numpy.random.Generator``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from identification._crc import crc8, int_to_bytes
from identification.manchester import Convention, encode_frame

__all__ = [
    "METRO_AXLE_OFFSETS_M",
    "ir_pulses_passage",
    "manchester_passage",
    "marking_detections",
    "reading_edges",
    "wheel_mark_passage",
]


def ir_pulses_passage(
    car_number: int,
    *,
    speed_kmh: float,
    rng: np.random.Generator,
    query_period_us: float = 1000.0,
    reflection_window_us: float = 200.0,
    zone_length_m: float = 2.0,
    reply_delay_us: float | None = None,
    jitter_us: float = 0.5,
    spurious_rate: float = 0.0,
    miss_rate: float = 0.0,
    echo_rate: float = 0.0,
    margin_cycles: int = 20,
) -> dict[str, Any]:
    """One car passing an infrared time-pulse reader → an ``ir_pulses`` payload.

    The transponder enters the zone with K = 0 and stays ``zone_length_m / v`` (whole query
    periods); it replies ``reply_delay_us`` after each query it answers.

    Parameters
    ----------
    car_number : int
        N >= 1.
    speed_kmh : float
        Train speed, km/h.
    rng : numpy.random.Generator
    query_period_us, reflection_window_us : float
        T_query and T_refl, µs.
    zone_length_m : float
        Reading-zone length, m.
    reply_delay_us : float, optional
        Reply delay after the query, µs; default: random per passage inside the listening
        window.
    jitter_us : float
        Gaussian jitter of each reply, µs.
    spurious_rate : float
        Probability per query cycle of an interference pulse at a random time of the cycle.
    miss_rate : float
        Probability that a reply is lost.
    echo_rate : float
        Probability per cycle of a wall reflection inside the blanking window.
    margin_cycles : int
        Up to this many empty cycles precede and follow the zone.

    Returns
    -------
    dict
        ``query_period_us``, ``reflection_window_us`` and ``reply_times_us`` (sorted, µs from
        the first query, 0.1 µs resolution).
    """
    if car_number < 1:
        raise ValueError("car numbers start at 1")
    period = float(query_period_us)
    blank = float(reflection_window_us)
    listen = period - blank
    delay = blank + rng.uniform(0.05, 0.6) * listen if reply_delay_us is None else reply_delay_us
    dwell_s = zone_length_m / (speed_kmh / 3.6)
    in_zone = int(dwell_s / (period * 1e-6))
    lead = int(rng.integers(0, margin_cycles + 1))
    total = lead + in_zone + int(rng.integers(0, margin_cycles + 1))

    k = np.arange(in_zone)
    r = k % (car_number + 1)
    reply_cycles = lead + k[(r == 0) | (r == car_number)]
    keep = rng.random(reply_cycles.size) >= miss_rate
    reply_cycles = reply_cycles[keep]
    replies = reply_cycles * period + delay + rng.normal(0.0, jitter_us, reply_cycles.size)

    cycles = np.arange(total)
    spur_c = cycles[rng.random(total) < spurious_rate]
    spurious = spur_c * period + rng.uniform(0.0, period, spur_c.size)
    echo_c = cycles[rng.random(total) < echo_rate]
    echoes = echo_c * period + rng.uniform(0.02, 0.98, echo_c.size) * blank

    times = np.sort(np.concatenate((replies, spurious, echoes)))
    times = np.round(np.clip(times, 0.0, None), 1)
    return {
        "query_period_us": period,
        "reflection_window_us": blank,
        "reply_times_us": times.tolist(),
    }


def manchester_passage(
    car_number: int,
    *,
    samples_per_bit: int = 8,
    rng: np.random.Generator,
    frames: float = 4.0,
    convention: Convention = "ieee",
    clock_error: float = 0.0,
    flip_prob: float = 0.0,
) -> dict[str, Any]:
    """A continuously repeating frame seen for ``frames`` frame durations → ``ir_manchester``.

    Parameters
    ----------
    car_number : int
        0…65535.
    samples_per_bit : int
        Nominal samples per bit, as the reader states it in the payload.
    rng : numpy.random.Generator
    frames : float
        Recording length in frame durations; it starts at a random point of the stream, so
        the first frame is usually cut.
    convention : {"ieee", "thomas"}
    clock_error : float
        The transponder's clock runs this much fast (0.05: +5 %, fewer samples per bit).
    flip_prob : float
        Probability that a sample is flipped.

    Returns
    -------
    dict
        ``samples_per_bit`` and ``samples`` (list of 0/1).
    """
    levels = np.asarray(encode_frame(car_number, convention=convention), dtype=np.int8)
    half_bits = levels.size
    spb_true = samples_per_bit / (1.0 + clock_error)
    n = int(round(frames * (half_bits / 2) * samples_per_bit))
    start = rng.uniform(0.0, half_bits)
    t = start + (np.arange(n) + rng.uniform(0.0, 1.0)) * 2.0 / spb_true  # in half-bits
    x = levels[np.floor(t).astype(np.int64) % half_bits]
    if flip_prob > 0:
        x = np.where(rng.random(n) < flip_prob, 1 - x, x)
    return {"samples_per_bit": samples_per_bit, "samples": x.astype(int).tolist()}


def _word_bits(code: int, *, axles: int, bits_per_axle: int, layout: str) -> list[int]:
    if layout == "duplicate":
        if not 0 <= code < 2**bits_per_axle:
            raise ValueError(f"code {code} does not fit in {bits_per_axle} bits")
        one = [int(c) for c in f"{code:0{bits_per_axle}b}"]
        return one * axles
    if layout == "distribute":
        total = axles * bits_per_axle
        if total <= 8 or not 0 <= code < 2 ** (total - 8):
            raise ValueError(f"code {code} does not fit in {total - 8} bits")
        word = (code << 8) | crc8(int_to_bytes(code, total - 8))
        return [int(c) for c in f"{word:0{total}b}"]
    raise ValueError(f"unknown layout {layout!r}")


def wheel_mark_passage(
    code: int,
    *,
    direction: int,
    rng: np.random.Generator,
    bits_per_axle: int = 8,
    axles: int = 4,
    layout: Literal["duplicate", "distribute"] = "duplicate",
    zero: float = 2048.0,
    amplitude: float = 400.0,
    fade: float = 0.7,
    noise: float = 0.1,
    strength_spread: float = 0.15,
    impulse: float | None = None,
    baseline_length: int = 6,
    adc_bits: int = 12,
) -> dict[str, Any]:
    """One car over a wheel-mark reader → a ``wheel_marks`` payload (ADC codes).

    Parameters
    ----------
    code : int
        The car's code (``bits_per_axle`` bits for ``duplicate``, N·B − 8 for ``distribute``).
    direction : {1, 2}
        Direction 2 reverses the passing order of axles and zones.
    rng : numpy.random.Generator
    bits_per_axle, axles : int
        Mark zones per axle (B) and axles (N).
    layout : {"duplicate", "distribute"}
    zero : float
        Zero level of the reader, ADC codes.
    amplitude : float
        Fresh mark amplitude, ADC codes.
    fade : float
        Fraction of the remanence lost (0.7: the thesis's ~70 % in the first ~100 km).
    noise : float
        Gaussian noise deviation, as a fraction of the faded amplitude.
    strength_spread : float
        Each wheel's mark strength varies uniformly by ± this fraction.
    impulse : float, optional
        One impulse of random sign at a random baseline sample, as a multiple of the faded
        amplitude.
    baseline_length : int
        Baseline samples (>= 5).
    adc_bits : int
        ADC resolution; codes are clipped to its range.

    Returns
    -------
    dict
        ``direction``, ``baseline`` (list of int) and ``axles`` (N lists of B ints).
    """
    if direction not in (1, 2):
        raise ValueError("direction must be 1 or 2")
    a = amplitude * (1.0 - fade)
    bits = np.asarray(_word_bits(code, axles=axles, bits_per_axle=bits_per_axle, layout=layout))
    strength = a * rng.uniform(1 - strength_spread, 1 + strength_spread, axles)
    values = zero + np.where(bits == 1, 1.0, -1.0) * np.repeat(strength, bits_per_axle)
    values += rng.normal(0.0, noise * a, values.size)
    if direction == 2:
        values = values[::-1]
    baseline = zero + rng.normal(0.0, noise * a, baseline_length)
    if impulse:
        baseline[rng.integers(0, baseline_length)] += rng.choice((-1.0, 1.0)) * impulse * a
    top = 2**adc_bits - 1
    adc_values = np.clip(np.rint(values), 0, top).astype(int).reshape(axles, bits_per_axle)
    adc_baseline = np.clip(np.rint(baseline), 0, top).astype(int)
    return {
        "direction": direction,
        "baseline": adc_baseline.tolist(),
        "axles": adc_values.tolist(),
    }


def reading_edges(
    passage: dict[str, Any],
    *,
    rng: np.random.Generator | None = None,
    oscillations: int = 0,
) -> list[tuple[str, Any] | str]:
    """The edges a reading section sees for a ``wheel_marks`` passage: the baseline DS samples,
    the zone sensor of entry, ``DOM k-j`` with the wheel's codes, and the zone sensor of exit.
    ``oscillations`` extra DOM hits (back-and-forth motion) and hits of the other direction's
    sensors are sprinkled in at random; the latches must ignore them."""
    j = int(passage["direction"])
    other = 3 - j
    edges: list[tuple[str, Any] | str] = [("DS", int(v)) for v in passage["baseline"]]
    edges.append(f"DZ{j}")
    for k, codes in enumerate(passage["axles"], 1):
        edges.append((f"DOM{k}-{j}", list(codes)))
        if rng is not None and oscillations > 0:
            for _ in range(int(rng.integers(0, oscillations + 1))):
                back = int(rng.integers(1, k + 1))
                edges.append((f"DOM{back}-{j}", [0] * len(codes)))
                edges.append((f"DOM{back}-{other}", [0] * len(codes)))
    edges.append(f"DZ{other}")
    return edges


#: Axle positions behind the leading end of a 19 m metro car (two two-axle bogies).
METRO_AXLE_OFFSETS_M = (1.9, 4.0, 15.2, 17.3)


def marking_detections(
    head_positions_m: Sequence[float],
    *,
    axle_offsets_m: Sequence[float] = METRO_AXLE_OFFSETS_M,
    w1_m: float = 0.0,
    w2_m: float = 1.0,
) -> list[str]:
    """Wheel-detector hits of a car moving along a track through the marking station.

    The car's leading end is at ``head_positions_m[t]`` (the car extends towards smaller
    positions; its axles are at ``head - offset``); W1 is at ``w1_m`` and W2 at ``w2_m``. A
    detector is hit each time an axle crosses it, in either direction; crossings within one
    step are ordered by when they happen. Reversals are any change of sign of the motion.
    """
    offs = np.asarray(axle_offsets_m, dtype=float)
    hits: list[tuple[int, float, str]] = []
    pos = np.asarray(head_positions_m, dtype=float)
    for step in range(1, pos.size):
        a0 = pos[step - 1] - offs
        a1 = pos[step] - offs
        for name, d in (("W1", w1_m), ("W2", w2_m)):
            crossed = (a0 >= d) != (a1 >= d)
            for k in np.flatnonzero(crossed):
                frac = (d - a0[k]) / (a1[k] - a0[k])
                hits.append((step, float(frac), name))
    hits.sort(key=lambda h: (h[0], h[1]))
    return [h[2] for h in hits]
