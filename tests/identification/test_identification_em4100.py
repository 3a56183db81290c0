"""The Manchester clock recovery on six real EM4102 RFID recordings (proxmark3 traces).

Expected IDs from shared/data/real/PROVENANCE.md (documented in the proxmark3 traces' README).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from identification.em4100 import decode_trace, load_pm3, parse_frame

TRACES = (
    Path(__file__).resolve().parents[2].parent / "shared" / "data" / "real" / "manchester_em4102"
)

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
