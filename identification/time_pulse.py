"""Infrared time-pulse identification (spec §3; thesis 002, chapter 3.1–3.3).

The station emits a query every ``T_query``; its receiver is blanked for ``T_refl`` after each
query (tunnel-wall echoes). The transponder of car N replies on the queries q, q+N, q+N+1,
q+2N+1, …: the reply gaps (in query cycles) alternate N and 1, and each N-gap is one read.

- :func:`decode_passage` — raw reply timings (protocol ``ir_pulses``) → reads → car number
  (strict majority of the reads, else None).
- :func:`detection_probabilities` — P_detect and P_false of an ideal low-pass receiver.
- :func:`plan_reader` — reading-zone length, dwell time, largest readable car number and the
  number of repeated reads at a speed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from identification.rules import RULES, IdentificationRules, agreed_number

MAX_QUERY_CYCLES = 2**53
"""Most query cycles a passage may span: cycle numbers are counted in float64 first,
which holds whole numbers exactly up to here (a real reader's passage spans thousands)."""

__all__ = [
    "Detection",
    "ReaderPlan",
    "TimePulseDecode",
    "decode_passage",
    "detection_probabilities",
    "pair_reads",
    "plan_reader",
]


@dataclass(frozen=True)
class TimePulseDecode:
    """Result of :func:`decode_passage`.

    ``reads``: the car numbers read (start/stop pairs that survived resynchronisation), in
    order. ``car_number``: their strict majority, or None (``reason`` says why).
    """

    car_number: int | None
    reads: list[int]
    reason: str
    reply_cycles: list[int] = field(default_factory=list)  # query cycles holding a reply
    reply_offset_us: float | None = None  # typical reply delay after the query
    pulses_blanked: int = 0  # pulses inside the blanking window (reflections)
    pulses_off_time: int = 0  # pulses outside the reply-time gate (interference)


def _cycles_and_offsets(
    t: npt.NDArray[np.float64],
    period: float,
    query_times_us: Sequence[float] | None,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Query cycle, offset after its query, and cycle length for each pulse time."""
    if query_times_us is None:
        cyc = np.floor(t / period).astype(np.int64)
        off = t - cyc * period
        length = np.full(t.shape, period)
        return cyc, off, length
    q = np.unique(np.asarray(query_times_us, dtype=np.float64))
    cyc = np.searchsorted(q, t, side="right").astype(np.int64) - 1
    ok = cyc >= 0
    cyc, t = cyc[ok], t[ok]
    off = t - q[cyc]
    nxt = np.append(q[1:], q[-1] + period) if q.size else q
    length = nxt[cyc] - q[cyc]
    return cyc, off, length


def _gate_centre(off: npt.NDArray[np.float64], tol: float) -> float | None:
    """Centre of the densest window of width 2·tol among the pulse offsets."""
    if off.size == 0:
        return None
    s = np.sort(off)
    hi = np.searchsorted(s, s + 2.0 * tol, side="right")
    counts = hi - np.arange(s.size)
    i = int(np.argmax(counts))
    return float(s[(i + int(hi[i]) - 1) // 2])  # the window's median


def pair_reads(reply_cycles: Sequence[int]) -> list[int]:
    """Start/stop pairing with resynchronisation.

    Replies alternate gaps N (a read) and 1 (stop → next start). A gap of more than one cycle
    is a read only when every neighbouring gap is a 1-gap (the first and last gap of the
    passage need only their one neighbour): a spurious reply splits an N-gap into two gaps that
    are not both framed by 1-gaps, and a missed reply merges gaps into an N+1 or 2N+1 gap that
    is not framed either, so an error costs a read or two instead of shifting the pairing for
    the rest of the passage. In a run of 1-gaps (car 1 replies every cycle) every other gap is
    a read, after the framing 1-gaps.

    Parameters
    ----------
    reply_cycles : sequence of int
        The distinct query cycles holding a reply, ascending.

    Returns
    -------
    list of int
        The reads (car numbers) in passage order.
    """
    c = np.asarray(reply_cycles, dtype=np.int64)
    if c.size < 2:
        return []
    g = np.diff(c)
    m = g.size
    one = g == 1
    # gaps > 1 framed by 1-gaps (or by the ends of the passage)
    left = np.concatenate(([True], one[:-1]))
    right = np.concatenate((one[1:], [True]))
    big_at = np.flatnonzero(~one & left & right)
    # runs of 1-gaps: every other gap is a read, after the framing 1-gaps at bounded ends
    edges = np.diff(np.concatenate(([0], one.astype(np.int8), [0])))
    run_start = np.flatnonzero(edges == 1)
    run_end = np.flatnonzero(edges == -1)
    bounded = (run_start > 0).astype(np.int64) + (run_end < m)
    ones = np.maximum(0, (run_end - run_start - bounded + 1) // 2)
    pos = np.concatenate((big_at, np.repeat(run_start, ones)))
    val = np.concatenate((g[big_at], np.ones(int(ones.sum()), np.int64)))
    return [int(v) for v in val[np.argsort(pos, kind="stable")]]


@dataclass(frozen=True)
class _Replies:
    cycles: npt.NDArray[np.int64]  # distinct query cycles holding a reply
    offset_us: float | None
    blanked: int
    off_time: int


def _replies(
    t: npt.NDArray[np.float64],
    period: float,
    blank: float,
    query_times_us: Sequence[float] | None,
    tol: float,
) -> _Replies:
    """Blanking, reply-time gate and merging: the query cycles that hold a reply."""
    cyc, off, length = _cycles_and_offsets(t, period, query_times_us)
    blanked = int(np.count_nonzero(off < blank))
    listening = (off >= blank) & (off < length)
    cyc, off = cyc[listening], off[listening]
    centre = _gate_centre(off, tol)
    off_time = 0
    if centre is not None:
        gate = np.abs(off - centre) <= tol
        off_time = int(np.count_nonzero(~gate))
        cyc = cyc[gate]
    return _Replies(np.unique(cyc), centre, blanked, off_time)


def _reads_needed(cycles: npt.NDArray[np.int64], number: int, minimum: int, fraction: float) -> int:
    """Agreeing reads a car number needs: a car in the zone for S cycles is read S/(N+1)
    times, so a handful of agreeing reads over a long passage is a coincidence of noise."""
    span = int(cycles[-1] - cycles[0] + 1) if cycles.size else 0
    return max(minimum, math.ceil(fraction * span / (number + 1)))


def decode_passage(
    reply_times_us: Sequence[float],
    *,
    query_period_us: float,
    reflection_window_us: float,
    query_times_us: Sequence[float] | None = None,
    reply_tolerance_us: float | None = None,
    min_read_fraction: float = 0.1,
    rules: IdentificationRules = RULES,
) -> TimePulseDecode:
    """Decode one ``ir_pulses`` passage.

    1. each pulse is assigned to its query cycle; pulses inside the blanking window are
       reflections and discarded;
    2. the transponder replies a fixed delay after the query, so its replies cluster at one
       offset: pulses further than ``reply_tolerance_us`` from the densest offset are
       interference and discarded;
    3. several pulses in one cycle merge into one reply;
    4. start/stop pairing with resynchronisation (:func:`pair_reads`) gives the reads;
    5. the car number is the strict majority of the reads, read at least
       ``rules.min_agreeing_reads`` times (repeated reading; the same rule as ``ir_id``,
       :func:`identification.rules.agreed_number`) and more often on a long passage
       (``min_read_fraction``); otherwise None.

    Parameters
    ----------
    reply_times_us : sequence of float
        Pulse times in µs (the ``ir_pulses`` event's ``reply_times_us``), any order.
    query_period_us : float
        T_query, µs (> 0).
    reflection_window_us : float
        T_refl, µs (>= 0): the receiver is blanked this long after each query.
    query_times_us : sequence of float, optional
        Query times, µs; default: queries at 0, T, 2T, …
    reply_tolerance_us : float, optional
        Half-width of the reply-time gate; default 5 % of the listening window T − T_refl.
    min_read_fraction : float
        Of the reads a car in the zone for the whole passage gives (span / (N + 1)), the
        fraction that must agree: a handful of reads over a long passage is noise.
    rules : IdentificationRules
        ``min_agreeing_reads``: the agreeing reads any car number needs.

    Returns
    -------
    TimePulseDecode
        ``car_number`` (None without a strict majority), ``reads`` and ``reason``.

    Raises
    ------
    ValueError
        If ``query_period_us`` is not a finite number > 0 or ``reflection_window_us`` < 0.
        (Pulses spanning more than :data:`MAX_QUERY_CYCLES` query periods give no car
        number, with the reason.)
    """
    period, blank = float(query_period_us), float(reflection_window_us)
    if not (math.isfinite(period) and period > 0) or not blank >= 0:
        raise ValueError(
            "query_period_us must be finite and > 0 and reflection_window_us >= 0, "
            f"got {period}, {blank}"
        )
    if not blank < period:
        return TimePulseDecode(None, [], "the blanking window is not shorter than the query period")
    if query_times_us is not None and len(query_times_us) == 0:
        return TimePulseDecode(None, [], "no query times given")
    if isinstance(reply_times_us, list | tuple):  # a payload's list: fromiter is faster
        t = np.fromiter(reply_times_us, dtype=np.float64, count=len(reply_times_us))
    else:
        t = np.asarray(reply_times_us, dtype=np.float64).reshape(-1)
    t = t[np.isfinite(t) & (t >= 0)]
    if t.size and float(t.max()) >= MAX_QUERY_CYCLES * period:
        # Like a blanking window as long as the period: the event is well-formed, its
        # numbers cannot come from one reader's passage, so no car number (not an error).
        reason = (
            f"the query period ({period} µs) is too short for pulses up to {float(t.max())} "
            f"µs: the passage would span more than {MAX_QUERY_CYCLES} query cycles"
        )
        return TimePulseDecode(None, [], reason)
    tol = 0.05 * (period - blank) if reply_tolerance_us is None else float(reply_tolerance_us)
    rep = _replies(t, period, blank, query_times_us, tol)
    reads = pair_reads(rep.cycles.tolist())
    number, reason = agreed_number(reads, rules=rules)
    if number is not None:
        need = _reads_needed(rep.cycles, number, rules.min_agreeing_reads, min_read_fraction)
        number, reason = agreed_number(reads, needed=need, rules=rules)
    return TimePulseDecode(
        car_number=number,
        reads=reads,
        reason=reason,
        reply_cycles=rep.cycles.tolist(),
        reply_offset_us=rep.offset_us,
        pulses_blanked=rep.blanked,
        pulses_off_time=rep.off_time,
    )


# ---------------------------------------------------------------------------------------------
# Noise immunity and reader planning (§3)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Detection:
    """Probabilities of detecting a reply pulse and of a false detection on noise alone."""

    p_detect: float
    p_false: float


def detection_probabilities(
    *,
    amplitude: float,
    threshold: float,
    noise_density: float,
    pulse_width: float,
    gain: float = 1.0,
) -> Detection:
    """P_detect and P_false of an ideal low-pass (gain K, bandwidth F = 1/τ) in white noise.

        P_detect = ½·[1 + erf((K·U − z0)·√τ / (K·√(2·N0)))]
        P_false  = ½·[1 − erf(z0·√τ / (K·√(2·N0)))]

    Parameters
    ----------
    amplitude : float
        Pulse amplitude U at the receiver input, V.
    threshold : float
        Decision threshold z0 at the filter output, V.
    noise_density : float
        White-noise density N0, V²/Hz (noise variance N0·F at the output of a unit-gain filter).
    pulse_width : float
        Pulse width τ, s (the bandwidth is F = 1/τ).
    gain : float
        Filter gain K.

    Returns
    -------
    Detection
        ``p_detect`` (a pulse is seen) and ``p_false`` (noise alone crosses the threshold).

    Raises
    ------
    ValueError
        If ``noise_density``, ``pulse_width`` or ``gain`` is not positive.
    """
    if noise_density <= 0 or pulse_width <= 0 or gain <= 0:
        raise ValueError("noise_density, pulse_width and gain must be positive")
    scale = math.sqrt(pulse_width) / (gain * math.sqrt(2.0 * noise_density))
    p_detect = 0.5 * (1.0 + math.erf((gain * amplitude - threshold) * scale))
    p_false = 0.5 * (1.0 - math.erf(threshold * scale))
    return Detection(p_detect=p_detect, p_false=p_false)


@dataclass(frozen=True)
class ReaderPlan:
    """Result of :func:`plan_reader`."""

    zone_length_m: float  # l = 2·R·tan(θ/2), or as given
    dwell_time_s: float  # t0 = l / v
    cycles_in_zone: int  # whole query periods in t0
    largest_car_number: int  # with ``reads_required`` complete reads inside the zone
    repeated_reads: int | None  # complete reads of ``car_number`` in the zone
    bits_at_baud: float | None  # what a continuous link at ``baud`` carries in t0


def plan_reader(
    *,
    speed_kmh: float,
    query_period_us: float,
    zone_length_m: float | None = None,
    range_m: float | None = None,
    beam_angle_deg: float | None = None,
    reads_required: int = 3,
    car_number: int | None = None,
    baud: float | None = None,
) -> ReaderPlan:
    """Reader planning for the time-pulse reader (spec §3).

    The zone is ``zone_length_m``, or l = 2·R·tan(θ/2) from the range and beam angle; the
    dwell time is t0 = l/v. The transponder answers from the first query in the zone, and the
    k-th read of car N ends on cycle k·(N+1) − 1, so ⌊cycles/(N+1)⌋ complete reads fit; the
    largest car number with ``reads_required`` reads is ⌊cycles/reads⌋ − 1. Thesis example:
    l = 2 m at 100 km/h → t0 = 7.2e-2 s.

    Parameters
    ----------
    speed_kmh : float
        Train speed, km/h.
    query_period_us : float
        T_query, µs.
    zone_length_m : float, optional
        Reading-zone length, m.
    range_m, beam_angle_deg : float, optional
        Transponder distance R (m) and radiation angle θ (degrees), when no zone length is given.
    reads_required : int
        Repeated reads wanted for the majority vote.
    car_number : int, optional
        A car number whose repeated reads are counted.
    baud : float, optional
        A continuous link's rate, to report the bits it carries in t0.

    Returns
    -------
    ReaderPlan

    Raises
    ------
    ValueError
        Without a zone length or range and angle, or for non-positive quantities.
    """
    if zone_length_m is None:
        if range_m is None or beam_angle_deg is None:
            raise ValueError("give zone_length_m, or range_m and beam_angle_deg")
        zone_length_m = 2.0 * range_m * math.tan(math.radians(beam_angle_deg) / 2.0)
    if speed_kmh <= 0 or query_period_us <= 0 or zone_length_m <= 0:
        raise ValueError("speed, query period and zone length must be positive")
    if reads_required < 1:
        raise ValueError("reads_required must be >= 1")
    v = speed_kmh / 3.6
    t0 = zone_length_m / v
    cycles = int(math.floor(t0 / (query_period_us * 1e-6) + 1e-9))
    largest = max(0, cycles // reads_required - 1)
    reads = None if car_number is None else cycles // (car_number + 1)
    return ReaderPlan(
        zone_length_m=zone_length_m,
        dwell_time_s=t0,
        cycles_in_zone=cycles,
        largest_car_number=largest,
        repeated_reads=reads,
        bits_at_baud=None if baud is None else baud * t0,
    )
