"""The review screen's alert sound: a two-tone chime, generated here and shipped as
``static/alert.wav`` (written by depot, under the project's licence; no third-party audio).

``python -m service.review.sound`` rewrites the file; a test checks the shipped file is this.
"""

from __future__ import annotations

import io
import wave
from dataclasses import dataclass
from pathlib import Path

import numpy as np

WAV = Path(__file__).parent / "static" / "alert.wav"


@dataclass(frozen=True)
class Chime:
    """Two falling tones, loud enough to be heard in a dispatcher's room, short enough to repeat.

    Attributes
    ----------
    rate_hz : sample rate of the file.
    tones_hz : pitch of each tone, in order (a falling fifth reads as "attention").
    tone_s : length of each tone, seconds.
    gap_s : silence between tones, seconds.
    level : peak amplitude as a fraction of full scale.
    decay_per_s : exponential decay rate of each tone's envelope (1/s).
    """

    rate_hz: int = 16_000
    tones_hz: tuple[float, ...] = (988.0, 659.0, 988.0, 659.0)
    tone_s: float = 0.16
    gap_s: float = 0.04
    level: float = 0.6
    decay_per_s: float = 9.0


def chime_wav(chime: Chime = Chime()) -> bytes:
    """The chime as 16-bit mono PCM WAV bytes (deterministic: same bytes on every machine)."""
    t = np.arange(int(chime.rate_hz * chime.tone_s)) / chime.rate_hz
    attack = np.minimum(1.0, t / 0.005)  # 5 ms ramp: no click at the start of a tone
    envelope = attack * np.exp(-chime.decay_per_s * t)
    gap = np.zeros(int(chime.rate_hz * chime.gap_s))
    parts = []
    for f in chime.tones_hz:
        parts += [envelope * np.sin(2 * np.pi * f * t), gap]
    samples = np.round(np.concatenate(parts) * chime.level * 32767).astype("<i2")
    out = io.BytesIO()
    with wave.open(out, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(chime.rate_hz)
        w.writeframes(samples.tobytes())
    return out.getvalue()


if __name__ == "__main__":  # pragma: no cover - regenerates the shipped file
    WAV.write_bytes(chime_wav())
    print(f"wrote {WAV}")
