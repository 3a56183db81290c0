"""The Manchester clock recovery on six real EM4102 RFID recordings (proxmark3 traces).

Expected IDs from shared/data/real/PROVENANCE.md (documented in the proxmark3 traces' README).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from identification.em4100 import decode_trace, frame_consensus, load_pm3, parse_frame

# The shared folder sits beside the checkout (/work/main or a worktree /work/wt/NAME): look up
# the ancestors, so that the real traces are found (not silently skipped) in a worktree too.
TRACES = next(
    (a / "shared" / "data" / "real" / "manchester_em4102" for a in Path(__file__).resolve().parents
     if (a / "shared" / "data" / "real").is_dir()),
    Path("/nonexistent/shared/data/real/manchester_em4102"),
)  # fmt: skip

EXPECTED = {
    "lf_EM4102-1.pm3": "010872e77c",
    "lf_EM4102-2.pm3": "010872beec",
    "lf_EM4102-3.pm3": "010872e14f",
    "lf_EM4102-clamshell.pm3": "1f00d9b3a5",
    "lf_EM4102-fob.pm3": "0400193cbe",
    "lf_EM4102-thin.pm3": "1a0041375d",
}


@pytest.mark.skipif(not TRACES.is_dir(), reason=f"real traces not present at {TRACES}")
@pytest.mark.parametrize(("name", "tag_id"), sorted(EXPECTED.items()))
def test_real_em4102_traces_decode_to_documented_ids(name: str, tag_id: str) -> None:
    r = decode_trace(load_pm3(TRACES / name))
    assert r.tag_id == tag_id
    assert r.frames_ok >= 1
    assert r.convention == "thomas"  # high→low = 1, as documented
    # the clock recovered from the analogue signal: RF/64
    assert r.samples_per_bit_estimate == pytest.approx(64.0, rel=0.01)


def _frame(tag: str) -> bytes:
    bits = "1" * 9
    nibbles = [int(c, 16) for c in tag]
    for n in nibbles:
        row = f"{n:04b}"
        bits += row + str(row.count("1") % 2)
    for col in range(4):
        bits += str(sum((n >> (3 - col)) & 1 for n in nibbles) % 2)
    return (bits + "0").encode()


def test_parse_frame_checks_parities() -> None:
    good = _frame("010872e77c")
    assert parse_frame(good) == "010872e77c"
    bad_row = bytearray(good)
    bad_row[10] ^= 1  # '0' <-> '1'
    assert parse_frame(bytes(bad_row)) is None
    assert parse_frame(good[:-1] + b"1") is None  # stop bit
    assert parse_frame(good[:63]) is None


def _variants(signal: np.ndarray) -> dict[str, np.ndarray]:
    med = float(np.median(signal))
    t = np.arange(signal.size, dtype=float)
    return {
        "as recorded": signal,
        "inverted": -signal,
        "clipped to ±30": np.clip(signal, med - 30, med + 30),
        "clipped to ±10": np.clip(signal, med - 10, med + 10),
        "stretched 4 %": np.interp(np.arange(0, signal.size - 1, 1 / 1.04), t, signal),
        "squeezed 4 %": np.interp(np.arange(0, signal.size - 1, 1.04), t, signal),
    }


@pytest.mark.skipif(not TRACES.is_dir(), reason=f"real traces not present at {TRACES}")
@pytest.mark.parametrize(("name", "tag_id"), sorted(EXPECTED.items()))
def test_real_traces_survive_inversion_clipping_and_clock_error(name: str, tag_id: str) -> None:
    for variant, signal in _variants(load_pm3(TRACES / name)).items():
        r = decode_trace(signal)
        assert (r.tag_id, r.reason) == (tag_id, "ok"), variant
        assert set(r.ids) == {tag_id}


@pytest.mark.skipif(not TRACES.is_dir(), reason=f"real traces not present at {TRACES}")
@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_a_time_reversed_trace_gives_no_id(name: str) -> None:
    # found by the independent trial: the reversed fob read 8 parity-valid frames of
    # 3be164c009 (its true ID is 0400193cbe). Reversed, clipped or not, it must give no ID.
    signal = load_pm3(TRACES / name)[::-1]
    for variant, reversed_signal in _variants(signal).items():
        r = decode_trace(reversed_signal)
        assert r.tag_id is None, (variant, r)
        assert r.reason != "ok"


def _frames_checked(text: bytes) -> tuple[str | None, str]:
    return frame_consensus(text)


def test_frames_of_different_ids_or_bit_phases_give_no_id() -> None:
    a, b = _frame("010872e77c"), _frame("1a0041375d")
    assert _frames_checked(a * 3) == ("010872e77c", "ok")
    tag, reason = _frames_checked(a * 2 + b)
    assert tag is None and "disagree" in reason
    tag, reason = _frames_checked(a + b"0" + a)  # the second frame one bit late
    assert tag is None and "bit phase" in reason


def test_an_empty_or_broken_trace_is_refused_clearly() -> None:
    with pytest.raises(ValueError, match="empty"):
        decode_trace(np.array([]))
    with pytest.raises(ValueError, match="finite"):
        decode_trace(np.array([1.0, np.nan, 2.0] * 100))
    assert decode_trace(np.zeros(5000)).tag_id is None  # silence: no frame, no crash
