"""Benchmark of the EOT radio decoder: speed as a multiple of real time on one core, and the
packets found on the real capture and on degraded copies of it (fixed seeds).

Run: ``.venv/bin/python -m bench.eot`` (about 10 s). Speed is the best of five runs in CPU
time of this process (``time.process_time``), so other load on the machine does not distort
it; the real-time factor is the audio's duration over that time (target ≥ 20×).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from identification.eot import decode_audio, read_wav
from identification.eot_channel import add_hum, add_noise, resample

RUNS = 5


def _capture() -> Path:
    for parent in Path(__file__).resolve().parents:
        path = parent / "shared" / "data" / "real" / "eot_radio" / "demo3eot.wav"
        if path.is_file():
            return path
    raise SystemExit("real capture shared/data/real/eot_radio/demo3eot.wav not found")


def speed(samples: np.ndarray, rate: int) -> float:
    """Real-time factor of :func:`decode_audio` on ``samples`` (best of ``RUNS``)."""
    best = float("inf")
    for _ in range(RUNS):
        start = time.process_time()
        decode_audio(samples, rate)
        best = min(best, time.process_time() - start)
    return samples.size / rate / best


def main() -> None:
    samples, rate = read_wav(_capture())
    reference = [p.bits for p in decode_audio(samples, rate)]
    rng = np.random.default_rng(7)
    copies = {
        "original (48 kHz, 8-bit)": (samples, rate),
        "resampled to 44.1 kHz": (resample(samples, rate, 44100), 44100),
        "resampled to 22.05 kHz": (resample(samples, rate, 22050), 22050),
        "resampled to 8 kHz": (resample(samples, rate, 8000), 8000),
        "SNR 8 dB": (add_noise(samples, snr_db=8.0, rng=rng), rate),
        "-30 dB level, 8-bit": (np.round(samples * 10 ** (-30 / 20)), rate),
        "transmitter clock +1.5 %": (resample(samples, rate, rate / 1.015), rate),
        "inverted": (-samples, rate),
        "50 Hz hum (0 dB) + 150 Hz": (add_hum(samples, rate), rate),
        "16-bit": (np.round(samples * 256), rate),
    }
    print(f"{'copy':32s} packets  same as original  real-time factor")
    for name, (audio, r) in copies.items():
        found = [p.bits for p in decode_audio(audio, r)]
        same = "yes" if found == reference else "NO"
        print(f"{name:32s} {len(found):7d}  {same:15s}  {speed(audio, r):8.1f}x")
    long_audio = np.tile(samples, 20)  # ~52 s, so fixed costs do not flatter the figure
    print(f"52 s of audio at 48 kHz: {speed(long_audio, rate):.1f}x real time on one core")


if __name__ == "__main__":
    main()
