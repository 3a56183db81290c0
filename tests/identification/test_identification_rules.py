"""One documented set of identification rules; weak or impossible evidence gives no car.

Found by the independent trial (each test failed before the fix): truncated wheel marks read as
another car, impossible ADC codes decoded, one axle or one IR read gave a confident ID.
"""

from __future__ import annotations

import dataclasses

import pytest

from identification import time_pulse
from identification.consist import majority_number
from identification.rules import RULES, IdentificationRules, agreed_number
from identification.wheel_marks import decode_passage

ONE, ZERO, ERASED, BASE = 2170, 1930, 2050, [2050] * 6


def _axle(code: int, zones: int = 8) -> list[int]:
    return [ONE if c == "1" else ZERO for c in f"{code:08b}"][:zones]


def test_the_rules_are_one_documented_dataclass() -> None:
    assert dataclasses.is_dataclass(IdentificationRules)
    assert RULES.zones_per_axle == 8  # the protocol's example: eight mark zones per axle
    assert (RULES.adc_min, RULES.adc_max) == (0, 4095)  # the 12-bit reader
    assert RULES.min_agreeing_reads == 2 and RULES.min_agreeing_axles == 2
    with pytest.raises(ValueError, match="min_agreeing_reads"):
        IdentificationRules(min_agreeing_reads=0)
    with pytest.raises(ValueError, match="adc"):
        IdentificationRules(adc_min=10, adc_max=5)


def test_truncated_axles_are_refused_against_the_fleets_code_length() -> None:
    r = decode_passage(BASE, [_axle(117, 7)] * 4, direction=1)
    assert r.code is None and r.reason == "axle 1 has 7 mark zones, 8 expected"
    assert decode_passage(BASE, [_axle(117)] * 4, direction=1).code == 117
    # a fleet with 7-zone marks says so explicitly
    assert decode_passage(BASE, [_axle(117, 7)] * 4, direction=1, bits_per_axle=7).code == 58


@pytest.mark.parametrize("bad", [1e300, -1, 4096, float("inf"), float("nan"), 10**400])
def test_codes_outside_the_adc_range_are_refused(bad: float) -> None:
    axles = [_axle(117) for _ in range(4)]
    axles[2][5] = bad  # type: ignore[call-overload]
    r = decode_passage(BASE, axles, direction=1)
    assert r.code is None and "outside the reader's range 0–4095" in r.reason
    assert "axle 3 zone 6" in r.reason
    r = decode_passage([*BASE[:-1], bad], [_axle(117)] * 4, direction=1)  # type: ignore[list-item]
    assert r.code is None and "baseline sample 6" in r.reason


def test_one_axle_never_identifies_a_car_alone_or_beside_erased_ones() -> None:
    alone = decode_passage(BASE, [_axle(119)], direction=1)
    beside = decode_passage(BASE, [_axle(119)] + [[ERASED] * 8] * 3, direction=1)
    assert alone.code is None and beside.code is None
    assert "2 agreeing axles needed" in alone.reason
    assert "2 agreeing axles needed" in beside.reason
    two = decode_passage(BASE, [_axle(119)] * 2 + [[ERASED] * 8] * 2, direction=1)
    assert two.code == 119
    # a stricter fleet rule is taken from the one rules object
    strict = IdentificationRules(min_agreeing_axles=3)
    r = decode_passage(BASE, [_axle(119)] * 2 + [[ERASED] * 8] * 2, direction=1, rules=strict)
    assert r.code is None and "3 agreeing axles needed" in r.reason


def test_ir_reads_need_the_same_number_of_agreeing_reads_everywhere() -> None:
    assert agreed_number([119]) == (None, "only 1 read(s) of 119; 2 needed")
    assert agreed_number([119, 119]) == (119, "ok")
    assert agreed_number([119, 119, 118]) == (119, "ok")
    assert agreed_number([119, 118])[0] is None
    assert agreed_number([]) == (None, "no reads")
    assert agreed_number([119] * 2, rules=IdentificationRules(min_agreeing_reads=3))[0] is None
    # the strict majority alone is still available, and the raw-timing decoder uses the same rule
    assert majority_number([119]) == 119
    single = time_pulse.decode_passage(
        [262.5, 119262.0], query_period_us=1000, reflection_window_us=200
    )
    assert single.reads == [119] and single.car_number is None
    assert single.reason == agreed_number([119])[1]
