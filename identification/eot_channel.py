"""What a radio channel and a receiver do to EOT audio, and an FFSK modulator (for tests,
the benchmark and the demo; the decoder in :mod:`identification.eot` never uses these).

All functions take and return new arrays; inputs are never modified. Levels are in the
input's own units.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["add_hum", "add_noise", "burst_power", "ffsk", "resample"]

FloatArray = npt.NDArray[np.float64]


def resample(x: npt.ArrayLike, rate_in: float, rate_out: float) -> FloatArray:
    """Band-limited resampling of ``x`` (shape (n,)) by zero-padding / truncating its spectrum.

    Resampling to ``rate / (1 + e)`` and playing at ``rate`` is a transmitter whose clock
    (tones and baud alike) runs ``e`` fast.
    """
    a = np.asarray(x, dtype=np.float64)
    n_out = int(round(a.size * rate_out / rate_in))
    spectrum = np.fft.rfft(a)
    out = np.zeros(n_out // 2 + 1, dtype=complex)
    keep = min(out.size, spectrum.size)
    out[:keep] = spectrum[:keep]
    return np.asarray(np.fft.irfft(out, n_out) * n_out / a.size, dtype=np.float64)


def burst_power(x: npt.ArrayLike, *, floor: float = 3.0) -> float:
    """Mean power of ``x`` where ``|x| > floor``: the power while a packet is on the air."""
    a = np.asarray(x, dtype=np.float64)
    return float(np.mean(a[np.abs(a) > floor] ** 2))


def add_noise(x: npt.ArrayLike, *, snr_db: float, rng: np.random.Generator) -> FloatArray:
    """``x`` plus white Gaussian noise at ``snr_db`` below the packets' power (full band)."""
    a = np.asarray(x, dtype=np.float64)
    sigma = np.sqrt(burst_power(a) / 10 ** (snr_db / 10))
    return np.asarray(a + rng.normal(0.0, sigma, a.size), dtype=np.float64)


def add_hum(
    x: npt.ArrayLike, rate: float, *, hum_db: float = 0.0, mains_hz: float = 50.0
) -> FloatArray:
    """``x`` plus mains hum ``hum_db`` relative to the packets' power, with a 3rd harmonic
    10 dB weaker."""
    a = np.asarray(x, dtype=np.float64)
    t = np.arange(a.size) / rate
    amplitude = np.sqrt(2 * burst_power(a)) * 10 ** (hum_db / 20)
    hum = np.sin(2 * np.pi * mains_hz * t + 0.3) + 0.3 * np.sin(2 * np.pi * 3 * mains_hz * t)
    return np.asarray(a + amplitude * hum, dtype=np.float64)


def ffsk(
    bits: str,
    rate: int,
    *,
    clock: float = 1.0,
    amplitude: float = 60.0,
    preamble_bits: int = 60,
) -> FloatArray:
    """Continuous-phase FFSK audio (mark 1200 Hz = 1, space 1800 Hz = 0, 1200 baud) of
    ``bits`` after an alternating preamble, with 0.1 s of silence either side.

    ``clock`` scales tones and baud together (1.01 = a transmitter 1 % fast).
    """
    line = "10" * (preamble_bits // 2) + bits + "0101"
    per_bit = rate / (1200.0 * clock)
    index = (np.arange(int(len(line) * per_bit)) / per_bit).astype(int)
    ones = np.frombuffer(line.encode(), np.uint8)[index] == ord("1")
    freq = np.where(ones, 1200.0, 1800.0) * clock
    tone = np.sin(2 * np.pi * np.cumsum(freq) / rate)
    gap = np.zeros(rate // 10)
    return np.asarray(np.concatenate((gap, amplitude * tone, gap)), dtype=np.float64)
