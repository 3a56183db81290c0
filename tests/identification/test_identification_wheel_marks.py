"""Wheel-mark decoding: baseline filter, decoding layouts, the protocol example, accuracy."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from identification._crc import crc8
from identification.simulate import wheel_mark_passage
from identification.wheel_marks import (
    A0_WEIGHTS,
    WheelDecode,
    decode_passage,
    frozen_zero,
    smooth_baseline,
)
from identification.wheel_marks import decode_passage as decode

# protocol.md, example wheel_marks event
EXAMPLE_BASELINE = [2051, 2049, 2050, 2052, 2048, 2050]
EXAMPLE_AXLES = [
    [2170, 1931, 2165, 2169, 1928, 1933, 2172, 1930],
    [2168, 1929, 2171, 2166, 1932, 1930, 2169, 1927],
    [2171, 1930, 2168, 2170, 1929, 1931, 2166, 1932],
    [2169, 1933, 2170, 2168, 1930, 1928, 2171, 1929],
]


def test_crc8_check_value() -> None:
    # CRC-8, poly 0x07, init 0, no reflection: standard check value of "123456789"
    assert crc8(b"123456789") == 0xF4


# ----------------------------------------------------------------------------- baseline filter


def test_smooth_baseline_weights_match_thesis() -> None:
    # the thesis writes (-6, 24, 34, 24, -6) / 70
    assert np.allclose(A0_WEIGHTS, np.array([-6, 24, 34, 24, -6]) / 70)
    assert smooth_baseline([0, 0, 0, 0, 35]) == pytest.approx(-3.0)
    assert smooth_baseline([0, 0, 35, 0, 0]) == pytest.approx(17.0)
    assert smooth_baseline([7, 7, 7, 7, 7]) == pytest.approx(7.0)


def test_smooth_baseline_uses_last_five_and_fits_quadratics_exactly() -> None:
    t = np.arange(-2, 3, dtype=float)
    quad = 5.0 + 2.0 * t - 0.7 * t**2  # a0 = 5 at t = 0
    assert smooth_baseline([999.0, -999.0, *quad]) == pytest.approx(5.0)


def test_smooth_baseline_noise_gain_is_sqrt595_over_35() -> None:
    assert math.sqrt(float(np.sum(A0_WEIGHTS**2))) == pytest.approx(math.sqrt(595) / 35)
    rng = np.random.default_rng(7)
    y = rng.normal(0.0, 1.0, (20000, 5))
    a0 = np.array([smooth_baseline(row.tolist()) for row in y])
    assert float(a0.std()) == pytest.approx(0.697, abs=0.02)


def test_smooth_baseline_frequency_response() -> None:
    # H(Ω) = (17 + 24 cos Ω − 6 cos 2Ω)/35: 1 at DC, low-pass
    for omega in (0.0, 0.5, 1.5, math.pi):
        n = np.arange(-2, 3)
        h = float(np.sum(A0_WEIGHTS[::-1] * np.cos(omega * n)))
        assert h == pytest.approx((17 + 24 * math.cos(omega) - 6 * math.cos(2 * omega)) / 35)
    assert (17 + 24 * math.cos(math.pi) - 6 * math.cos(2 * math.pi)) / 35 < 0.0


def test_smooth_baseline_rejects_short_input() -> None:
    with pytest.raises(ValueError, match="five"):
        smooth_baseline([1, 2, 3, 4])


def test_frozen_zero_rejects_an_impulse_the_filter_alone_would_pass() -> None:
    base = [2050, 2049, 2051, 2050, 2650, 2050, 2049]  # +600 impulse, 2 samples before entry
    assert smooth_baseline(base) > 2050 + 0.3 * 600  # a0 alone keeps 34 % of it
    assert frozen_zero(base) == pytest.approx(2050, abs=1.0)


# ----------------------------------------------------------------------------- decoding


def test_protocol_example_decodes_to_178() -> None:
    r = decode_passage(EXAMPLE_BASELINE, EXAMPLE_AXLES, direction=1)
    assert r.code == 0b10110010 == 178
    assert r.reason == "ok"
    assert r.readable_axles == 4
    assert r.zero == pytest.approx((-3 * 2049 + 12 * 2050 + 17 * 2052 + 12 * 2048 - 3 * 2050) / 35)
    assert r.margin is not None and 0.9 < r.margin < 1.1
    # in direction 2 the zones are read in reverse: 01001101
    assert decode_passage(EXAMPLE_BASELINE, EXAMPLE_AXLES, direction=2).code == 77


def test_direction_two_restores_the_cars_own_order() -> None:
    rng = np.random.default_rng(3)
    for code in (1, 117, 200):
        p = wheel_mark_passage(code, direction=2, rng=rng)
        assert decode_passage(p["baseline"], p["axles"], direction=2).code == code
        # read as if in direction 1, the bits come out in passing order: reversed
        reversed_code = int(f"{code:08b}"[::-1], 2)
        assert decode_passage(p["baseline"], p["axles"], direction=1).code == reversed_code


def test_distribute_layout_with_crc() -> None:
    # N=4 axles × B=4 bits: code 0xA7 then crc8([0xA7])
    code = 0xA7
    word = (code << 8) | crc8([code])
    bits = [int(c) for c in f"{word:016b}"]
    axles = [[2050 + (120 if b else -120) for b in bits[4 * k : 4 * k + 4]] for k in range(4)]
    base = [2050] * 5
    r = decode_passage(base, axles, direction=1, layout="distribute", bits_per_axle=4)
    assert (r.code, r.reason) == (code, "ok")
    # reversed stream in direction 2
    rev = [list(reversed(a)) for a in reversed(axles)]
    assert decode_passage(base, rev, direction=2, layout="distribute", bits_per_axle=4).code == code
    # one flipped mark breaks the CRC: no code, never a wrong one
    bad = [row[:] for row in axles]
    bad[2][1] = 4100 - bad[2][1]
    r = decode_passage(base, bad, direction=1, layout="distribute", bits_per_axle=4)
    assert r.code is None and r.reason == "CRC mismatch"


def test_distribute_needs_more_than_eight_bits() -> None:
    r = decode_passage(
        [2050] * 5, [[2150, 1950]] * 4, direction=1, layout="distribute", bits_per_axle=2
    )
    assert r.code is None and "more than 8 bits" in r.reason


def test_duplicate_majority_and_ties() -> None:
    one, zero, weak = 2170, 1930, 2055
    base = [2050] * 5

    def decode_passage(*args: Any, **kwargs: Any) -> WheelDecode:
        return decode(*args, bits_per_axle=2, **kwargs)

    # one axle disagrees on bit 0: the majority of 3 vs 1 wins
    axles = [[one, zero], [one, zero], [one, zero], [zero, zero]]
    assert decode_passage(base, axles, direction=1).code == 0b10
    # 2 vs 2 on bit 0: no majority
    r = decode_passage(base, [[one, zero], [one, zero], [zero, zero], [zero, zero]], direction=1)
    assert r.code is None and "no majority" in r.reason
    # three of four axles erased on bit 1
    r = decode_passage(base, [[one, zero], [one, weak], [one, weak], [one, weak]], direction=1)
    assert r.code is None and "erased on 3 of 4" in r.reason
    assert r.readable_axles == 1


def test_faint_marks_below_noise_floor_are_erasures() -> None:
    r = decode_passage([2050] * 5, [[2060, 2040]] * 4, direction=1, bits_per_axle=2)
    assert r.code is None and r.threshold == 30.0


@pytest.mark.parametrize(
    ("kwargs", "reason"),
    [
        (
            {"axles": [[2170, 1930], [2170]], "bits_per_axle": 2},
            "axle 2 has 1 mark zones, 2 expected",
        ),
        ({"axles": [[2170, 1930]] * 3, "axles_expected": 4}, "3 axles read, 4 expected"),
        ({"axles": [[2170, 1930]] * 4}, "axle 1 has 2 mark zones, 8 expected"),
        ({"axles": [[2170, 1930]] * 4, "bits_per_axle": 3}, "axle 1 has 2 mark zones, 3 expected"),
        ({"axles": [], "bits_per_axle": 2}, "no axles read"),
        ({"baseline": [2050] * 4, "bits_per_axle": 2}, "baseline has 4 samples"),
    ],
)
def test_undecodable_payloads_give_a_reason(kwargs: dict[str, object], reason: str) -> None:
    args: dict[str, object] = {"baseline": [2050] * 5, "axles": [[2170, 1930]] * 4}
    args.update(kwargs)
    r = decode_passage(args.pop("baseline"), args.pop("axles"), direction=1, **args)  # type: ignore[arg-type]
    assert r.code is None and reason in r.reason


def test_bad_parameters_raise() -> None:
    with pytest.raises(ValueError, match="direction"):
        decode_passage([0] * 5, [[1]], direction=3)
    with pytest.raises(ValueError, match="layout"):
        decode_passage([0] * 5, [[1]], direction=1, layout="spread")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="bits_per_axle"):
        decode_passage([0] * 5, [[1]], direction=1, bits_per_axle=0)


def test_inputs_are_not_modified() -> None:
    base = list(EXAMPLE_BASELINE)
    axles = [list(a) for a in EXAMPLE_AXLES]
    decode_passage(base, axles, direction=2)
    assert base == EXAMPLE_BASELINE and axles == EXAMPLE_AXLES


# ----------------------------------------------------------------------------- accuracy


def _accuracy(n: int, seed: int, **kw: object) -> tuple[int, int, int]:
    rng = np.random.default_rng(seed)
    right = wrong = 0
    layout = kw.get("layout", "duplicate")
    for _ in range(n):
        code = int(rng.integers(0, 2 ** (24 if layout == "distribute" else 8)))
        direction = int(rng.integers(1, 3))
        p = wheel_mark_passage(code, direction=direction, rng=rng, **kw)  # type: ignore[arg-type]
        r = decode_passage(
            p["baseline"],
            p["axles"],
            direction=p["direction"],
            layout=layout,  # type: ignore[arg-type]
        )
        right += r.code == code
        wrong += r.code is not None and r.code != code
    return right, wrong, n - right - wrong


def test_accuracy_faded_noisy_marks_with_baseline_impulse() -> None:
    # marks faded by 70 %, noise 10 % of the faded amplitude, one 5× impulse in the baseline
    right, wrong, _ = _accuracy(1500, seed=11, fade=0.7, noise=0.1, impulse=5.0)
    assert right / 1500 >= 0.99  # measured: 1500 / 1500
    assert wrong / 1500 <= 0.001  # measured: 0


def test_accuracy_distribute_layout() -> None:
    right, wrong, _ = _accuracy(
        1000, seed=12, fade=0.7, noise=0.1, impulse=5.0, layout="distribute"
    )
    assert right / 1000 >= 0.99  # measured: 993 / 1000 (a lone erased bit gives None)
    assert wrong == 0


def test_heavy_noise_gives_none_not_wrong_codes() -> None:
    right, wrong, none = _accuracy(1000, seed=13, fade=0.7, noise=0.35, impulse=5.0)
    assert wrong == 0
    assert none > 0 and right > 800  # measured: 842 right, 158 None
