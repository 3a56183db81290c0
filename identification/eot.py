"""End-of-train (EOT) radio packets from FM-demodulated audio (spec: identification.md, "EOT").

Line code: FFSK at 1200 baud, mark 1200 Hz = 1, space 1800 Hz = 0. A packet is 74 bits:
frame sync ``11100010010`` (bits 0–10), battery condition 13–14, message type 15–17, unit
address 18–34, brake-pipe pressure (psig) 35–41, battery charge 42–48, flags 49–55, BCH check
bits 56–73; multi-bit fields least significant bit first.

Receiver (:func:`decode_audio`), built to hold up to real radio receivers:

1. band-pass FIR around the two tones (removes DC, mains hum and its low harmonics, hiss);
2. non-coherent tone detection: each tone is mixed to baseband and integrated over one bit,
   so the discriminator ``(E_mark - E_space) / (E_mark + E_space)`` in [-1, 1] ignores the
   audio's polarity and level;
3. timing recovery: a second-order (phase and rate) digital PLL on the discriminator's zero
   crossings, so a transmitter clock a few per cent off and any sample rate are tracked
   rather than sampled at fixed instants;
4. frame-sync search and the BCH check; a packet that fails it is never reported.
"""

from __future__ import annotations

import wave
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from identification.eot_packet import FRAME_SYNC, PACKET_BITS, EotPacket, bch_valid, parse_packet

__all__ = [
    "FRAME_SYNC",
    "PACKET_BITS",
    "DecoderTuning",
    "EotPacket",
    "bch_valid",
    "decode_audio",
    "decode_wav",
    "parse_packet",
    "read_wav",
]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class DecoderTuning:
    """Every tunable of the receiver, in one place.

    Attributes
    ----------
    baud, mark_hz, space_hz
        The line code (AAR EOT: 1200 baud, mark 1200 Hz, space 1800 Hz).
    channel_hz
        Cut-off of the channel filter after mixing down by the centre frequency, Hz: passes
        both tones with their modulation sidebands (centre ± 1000 Hz = 500–2500 Hz) and
        stops 50/60 Hz hum (≈ 1450 Hz away) and the mixing image (3000 Hz away).
    filter_s
        Length of the channel FIR, seconds (its transition width is ≈ 3.3 / filter_s Hz).
    clip
        Bound on the per-sample normalised frequency: limits FM clicks in noise.
    bias_bits
        Span, in bits, of the running mean taken as the tones' common frequency offset; long
        against the runs of equal bits in a packet, short against a packet.
    min_rate_hz
        Lowest sample rate accepted: the space tone needs margin below Nyquist.
    phase_gain, rate_gain
        Loop gains of the timing PLL per zero crossing (fraction of the measured timing error
        applied to the bit phase and to the bit period).
    max_clock_error
        Bound on the tracked bit period relative to nominal (±); beyond it the PLL is held at
        the bound instead of wandering on noise between packets.
    min_confidence
        A crossing moves the clock only if the discriminator half a bit either side of it has
        at least this magnitude (zero crossings in noise carry no timing).
    unlocked_error, lock_crossings
        Lock detector: the mean absolute timing error (in bits) over about ``lock_crossings``
        crossings is near 0 when locked to a packet and about 0.25 on noise. Above
        ``unlocked_error`` the loop counts as unlocked and its rate is reset to nominal, so
        that each packet is acquired from a clean start instead of from a rate that wandered
        on the noise before it.
    """

    baud: float = 1200.0
    mark_hz: float = 1200.0
    space_hz: float = 1800.0
    channel_hz: float = 1000.0
    filter_s: float = 0.004
    clip: float = 3.0
    bias_bits: float = 96.0
    min_rate_hz: float = 7900.0
    phase_gain: float = 0.35
    rate_gain: float = 0.02
    max_clock_error: float = 0.06
    min_confidence: float = 0.3
    unlocked_error: float = 0.2
    lock_crossings: float = 8.0


DEFAULT_TUNING = DecoderTuning()


def _channel_filter(rate: float, tuning: DecoderTuning) -> FloatArray:
    """Hamming-windowed-sinc low-pass kernel (odd length, zero phase, unit DC gain)."""
    taps = int(round(tuning.filter_s * rate)) | 1  # odd: a centred, zero-phase filter
    n = np.arange(taps) - taps // 2
    cutoff = tuning.channel_hz / rate
    kernel = 2 * cutoff * np.sinc(2 * cutoff * n) * np.hamming(taps)
    return np.asarray(kernel / kernel.sum(), dtype=np.float64)


def _box(x: FloatArray, length: int) -> FloatArray:
    """Centred moving average of ``length`` samples (shorter at the ends)."""
    csum = np.concatenate(([0.0], np.cumsum(x)))
    idx = np.arange(x.size)
    hi = np.minimum(idx + length - length // 2, x.size)
    lo = np.maximum(idx - length // 2, 0)
    return np.asarray((csum[hi] - csum[lo]) / (hi - lo), dtype=np.float64)


def discriminator(
    samples: npt.ArrayLike, rate: float, *, tuning: DecoderTuning = DEFAULT_TUNING
) -> FloatArray:
    """Soft bit signal: about +1 on the mark tone, -1 on the space tone.

    The audio is mixed down by the centre frequency between the tones, low-pass filtered
    (the channel filter, which also removes DC, mains hum and the mixing image), and its
    instantaneous frequency is measured from the phase step between samples. A frequency
    does not depend on the audio's level or polarity. One bit of moving average is the
    matched filter for the resulting NRZ signal.

    Parameters
    ----------
    samples
        Audio, shape (n,), any scale and polarity.
    rate
        Sample rate, Hz.

    Returns
    -------
    FloatArray
        Shape (n,), at the input's sample rate: (centre − frequency) / deviation, each sample
        clipped to ±``tuning.clip`` before the bit average (FM clicks in noise).
    """
    x = np.asarray(samples, dtype=np.float64).ravel()
    centre = (tuning.mark_hz + tuning.space_hz) / 2
    deviation = abs(tuning.space_hz - tuning.mark_hz) / 2
    phase = (centre / rate * np.arange(x.size)) % 1.0  # wrapped: exact for long files
    baseband = np.convolve(
        (x - x.mean()) * np.exp(-2j * np.pi * phase), _channel_filter(rate, tuning), mode="same"
    )
    step = np.angle(baseband[1:] * np.conj(baseband[:-1])) * rate / (2 * np.pi)
    sign = 1.0 if tuning.space_hz > tuning.mark_hz else -1.0
    freq = np.clip(-sign * np.concatenate((step[:1], step)) / deviation, -tuning.clip, tuning.clip)
    bit = max(int(round(rate / tuning.baud)), 2)
    soft = _box(freq, bit)
    # A transmitter off frequency shifts both tones alike: a bias, removed as the mean over
    # many bits, so that the slicer and the zero crossings stay centred between the tones.
    # The mean is weighted by the in-channel power, so that the silence around a packet (or
    # the faint residue of hum in it, whose "frequency" is far off) does not pull it.
    power = _box(baseband.real**2 + baseband.imag**2, bit)
    span = int(tuning.bias_bits * bit)
    bias = _box(soft * power, span) / (_box(power, span) + np.finfo(np.float64).tiny)
    return np.asarray(soft - bias, dtype=np.float64)


def _crossings(d: FloatArray) -> FloatArray:
    """Fractional sample positions where ``d`` changes sign."""
    idx = np.flatnonzero(np.signbit(d[:-1]) != np.signbit(d[1:]))
    step = d[idx] - d[idx + 1]
    frac = np.divide(d[idx], step, out=np.full(idx.size, 0.5), where=step != 0)
    return np.asarray(idx + frac, dtype=np.float64)


def _transitions(d: FloatArray, period: float, tuning: DecoderTuning) -> FloatArray:
    """Zero crossings of ``d`` that are bit transitions: full-level bits half a bit either side.

    Judged from the signal around each crossing, whatever the loop's phase: judging at the
    loop's own sampling instants instead would freeze a loop that has locked onto the
    transitions (its samples would all be near zero).
    """
    cross = _crossings(d)
    grid = np.arange(d.size)
    before = np.abs(np.interp(cross - period / 2, grid, d))
    after = np.abs(np.interp(cross + period / 2, grid, d))
    return cross[np.minimum(before, after) >= tuning.min_confidence]


def recover_bits(
    d: FloatArray, rate: float, *, tuning: DecoderTuning = DEFAULT_TUNING
) -> tuple[str, FloatArray]:
    """Bits and their sampling times from a discriminator signal, by a timing PLL.

    Parameters
    ----------
    d
        Discriminator output, shape (n,) (see :func:`discriminator`).
    rate
        Its sample rate, Hz.

    Returns
    -------
    (str, FloatArray)
        The bit string and, shape (bits,), each bit's sampling instant in samples.
    """
    nominal = rate / tuning.baud
    bounds = (nominal * (1 - tuning.max_clock_error), nominal * (1 + tuning.max_clock_error))
    cross = _transitions(d, nominal, tuning).tolist()
    last = d.size - 1
    period, t, ci, lock = nominal, nominal / 2, 0, 0.25
    smoothing = 1.0 / tuning.lock_crossings
    times: list[float] = []
    while t + period < last:
        nxt = t + period
        while ci < len(cross) and cross[ci] <= t:
            ci += 1
        hits: list[float] = []
        while ci < len(cross) and cross[ci] <= nxt:
            hits.append(cross[ci])
            ci += 1
        if len(hits) == 1:  # several in one bit: noise, no timing in them
            error = (hits[0] - (t + period / 2)) / period
            nxt += tuning.phase_gain * error * period
            lock += smoothing * (abs(error) - lock)
            if lock > tuning.unlocked_error:
                period = nominal
            else:
                period = min(max(period * (1 + tuning.rate_gain * error), bounds[0]), bounds[1])
        times.append(nxt)
        t = nxt
    at = np.asarray(times, dtype=np.float64)
    bits = np.interp(at, np.arange(d.size), d) > 0
    return "".join("1" if b else "0" for b in bits), at


def decode_audio(
    samples: npt.ArrayLike, rate: float, *, tuning: DecoderTuning = DEFAULT_TUNING
) -> list[EotPacket]:
    """Every BCH-valid EOT packet in FM-demodulated audio, in order of time.

    Parameters
    ----------
    samples
        Audio, shape (n,) or (n, channels) (channels are averaged); any scale, offset and
        polarity. Not modified.
    rate
        Sample rate, Hz, at least 8 kHz.

    Returns
    -------
    list[EotPacket]
        Packets that pass the frame sync and BCH check; ``at_s`` is each one's start time.
    """
    if rate < tuning.min_rate_hz:
        raise ValueError(f"sample rate {rate:g} Hz is too low: EOT audio needs at least 8 kHz")
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim == 2:
        x = x.mean(axis=1)
    if x.ndim != 1:
        raise ValueError("samples must be shape (n,) or (n, channels)")
    if x.size < 2 * rate / tuning.baud * PACKET_BITS / 2 or not np.all(np.isfinite(x)):
        return []
    bits, at = recover_bits(discriminator(x, rate, tuning=tuning), rate, tuning=tuning)
    packets: list[EotPacket] = []
    start = bits.find(FRAME_SYNC)
    while start != -1 and start + PACKET_BITS <= len(bits):
        candidate = bits[start : start + PACKET_BITS]
        if bch_valid(candidate):
            packets.append(parse_packet(candidate, at_s=float(at[start]) / rate))
            start = bits.find(FRAME_SYNC, start + PACKET_BITS)
        else:
            start = bits.find(FRAME_SYNC, start + 1)
    return packets


def _why(path: str | Path, exc: Exception) -> str:
    """Why a WAV file could not be read, in words (``wave`` often raises with no message)."""
    if isinstance(exc, FileNotFoundError):
        return "no such file"
    if isinstance(exc, IsADirectoryError):
        return "it is a directory"
    if isinstance(exc, OSError):
        return exc.strerror or type(exc).__name__
    if Path(path).is_file() and Path(path).stat().st_size == 0:
        return "the file is empty"
    if isinstance(exc, EOFError) or not str(exc):
        return "the file ends inside its WAV header: truncated"
    return str(exc)


def read_wav(path: str | Path) -> tuple[FloatArray, int]:
    """Samples (float, channels averaged, centred at zero) and sample rate of a PCM WAV file.

    Raises
    ------
    ValueError
        The file is missing, not a WAV file, or not 8/16/24/32-bit integer PCM.
    """
    try:
        with wave.open(str(path), "rb") as wav:
            width, channels, rate = wav.getsampwidth(), wav.getnchannels(), wav.getframerate()
            raw = wav.readframes(wav.getnframes())
    except (wave.Error, EOFError, OSError) as exc:
        raise ValueError(f"{path}: not a readable PCM WAV file ({_why(path, exc)})") from None
    if width == 1:
        data = np.frombuffer(raw, dtype=np.uint8).astype(np.float64) - 128.0
    elif width == 3:
        b = np.frombuffer(raw, dtype=np.uint8).reshape(-1, 3).astype(np.int32)
        data = ((b[:, 0] | b[:, 1] << 8 | b[:, 2] << 16) << 8 >> 8).astype(np.float64)
    elif width in (2, 4):
        data = np.frombuffer(raw, dtype=f"<i{width}").astype(np.float64)
    else:
        raise ValueError(f"{path}: {8 * width}-bit samples are not supported (8/16/24/32-bit)")
    usable = data.size - data.size % channels
    return data[:usable].reshape(-1, channels).mean(axis=1), rate


def decode_wav(path: str | Path, *, tuning: DecoderTuning = DEFAULT_TUNING) -> list[EotPacket]:
    """Every BCH-valid EOT packet in a WAV recording (see :func:`decode_audio`)."""
    samples, rate = read_wav(path)
    return decode_audio(samples, rate, tuning=tuning)
