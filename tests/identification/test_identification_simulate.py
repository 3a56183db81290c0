"""Simulators produce protocol payloads that the decoders read with default parameters."""

from __future__ import annotations

import numpy as np
import pytest

from identification import manchester, simulate, time_pulse, wheel_marks


def test_ir_pulses_payload_matches_the_protocol_and_decodes() -> None:
    rng = np.random.default_rng(1)
    p = simulate.ir_pulses_passage(117, speed_kmh=5.0, rng=rng)
    assert set(p) == {"query_period_us", "reflection_window_us", "reply_times_us"}
    assert all(isinstance(t, float) for t in p["reply_times_us"])
    assert p["reply_times_us"] == sorted(p["reply_times_us"])
    r = time_pulse.decode_passage(**p)
    assert r.car_number == 117


def test_manchester_payload_matches_the_protocol_and_decodes() -> None:
    rng = np.random.default_rng(2)
    p = simulate.manchester_passage(117, samples_per_bit=8, rng=rng)
    assert set(p) == {"samples_per_bit", "samples"}
    assert set(p["samples"]) == {0, 1}
    assert manchester.decode_passage(**p).car_number == 117


def test_wheel_marks_payload_matches_the_protocol_and_decodes() -> None:
    rng = np.random.default_rng(3)
    p = simulate.wheel_mark_passage(117, direction=2, rng=rng)
    assert set(p) == {"direction", "baseline", "axles"}
    assert len(p["baseline"]) >= 5 and len(p["axles"]) == 4
    assert all(isinstance(c, int) for axle in p["axles"] for c in axle)
    assert wheel_marks.decode_passage(**p).code == 117


def test_simulators_are_reproducible_and_validate() -> None:
    a = simulate.wheel_mark_passage(5, direction=1, rng=np.random.default_rng(9))
    b = simulate.wheel_mark_passage(5, direction=1, rng=np.random.default_rng(9))
    assert a == b
    with pytest.raises(ValueError, match="fit"):
        simulate.wheel_mark_passage(256, direction=1, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="direction"):
        simulate.wheel_mark_passage(5, direction=0, rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match="start at 1"):
        simulate.ir_pulses_passage(0, speed_kmh=5.0, rng=np.random.default_rng(0))


def test_noise_knobs_do_what_they_say() -> None:
    rng = np.random.default_rng(4)
    clean = simulate.ir_pulses_passage(50, speed_kmh=10.0, rng=rng, reply_delay_us=300.0)
    t = np.asarray(clean["reply_times_us"])
    assert np.allclose(t % 1000.0, 300.0, atol=3.0)  # replies only, at the reply delay
    echoes = simulate.ir_pulses_passage(50, speed_kmh=10.0, rng=rng, echo_rate=1.0)
    offs = np.asarray(echoes["reply_times_us"]) % 1000.0
    assert np.count_nonzero(offs < 200.0) > 700  # a reflection in every blanking window
