"""Decoder fuzzing: arbitrary payloads give a result or a clear ValueError/TypeError, and a
corrupted passage of car N never decodes to another car.

Short form: a few dozen derandomised examples per property (~30 s); ``DEPOT_SOAK=1`` runs ten
times as many, randomised.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import tail_check
from identification import manchester, time_pulse, wheel_marks
from identification.consist import majority_number
from identification.simulate import ir_pulses_passage, manchester_passage, wheel_mark_passage
from tests.reliability.relkit import SOAK

CLEAR = (ValueError, TypeError)
FUZZ = settings(
    max_examples=400 if SOAK else 60,
    deadline=None,
    derandomize=not SOAK,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
any_float = st.floats(allow_nan=True, allow_infinity=True)
any_number = st.one_of(any_float, st.integers(-(2**70), 2**70))
cars = st.integers(1, 9999)


def _result_or_clear_error(call: Any) -> Any:
    try:
        return call()
    except CLEAR:
        return None


@FUZZ
@given(
    st.lists(any_float, max_size=300),
    any_number,
    any_number,
    st.none() | st.lists(any_float, max_size=50),
)
def test_time_pulse_any_payload(
    replies: list[float], period: Any, blank: Any, queries: Any
) -> None:
    result = _result_or_clear_error(
        lambda: time_pulse.decode_passage(
            replies, query_period_us=period, reflection_window_us=blank, query_times_us=queries
        )
    )
    assert result is None or result.car_number is None or result.car_number >= 0


@FUZZ
@given(
    st.lists(st.integers(-5, 5), max_size=5000) | st.lists(st.sampled_from([0, 1]), max_size=5000),
    any_number,
)
def test_manchester_any_payload(samples: list[int], samples_per_bit: Any) -> None:
    _result_or_clear_error(
        lambda: manchester.decode_passage(samples, samples_per_bit=samples_per_bit)
    )


@FUZZ
@given(
    st.lists(any_number, max_size=20),
    st.lists(st.lists(any_number, max_size=12), max_size=8),
    st.integers(-3, 5),
)
def test_wheel_marks_any_payload(
    baseline: list[Any], axles: list[list[Any]], direction: int
) -> None:
    result = _result_or_clear_error(
        lambda: wheel_marks.decode_passage(baseline, axles, direction=direction)
    )
    assert result is None or result.code is None or result.code >= 0


@FUZZ
@given(st.lists(st.integers(-(2**40), 2**40), max_size=200))
def test_majority_number_is_a_strict_majority(reads: list[int]) -> None:
    number = majority_number(reads)
    if number is not None:
        assert 2 * reads.count(number) > len(reads)
    else:
        assert not reads or all(2 * reads.count(r) <= len(reads) for r in set(reads))


@FUZZ
@given(cars, st.integers(0, 2**32 - 1), st.lists(st.floats(0, 1), max_size=8), st.integers(0, 8))
def test_time_pulse_corrupted_never_another_car(
    car: int, seed: int, extra: list[float], drops: int
) -> None:
    """Interference pulses anywhere in the passage and lost replies: car N or no number."""
    rng = np.random.default_rng(seed)
    passage = ir_pulses_passage(car, speed_kmh=float(rng.uniform(5, 120)), rng=rng)
    times = list(passage["reply_times_us"])
    span = max(times[-1], 1.0) if times else 1.0
    for _ in range(min(drops, len(times))):
        times.pop(int(rng.integers(0, len(times))))
    times += [f * span for f in extra]
    result = time_pulse.decode_passage(
        times,
        query_period_us=passage["query_period_us"],
        reflection_window_us=passage["reflection_window_us"],
    )
    assert result.car_number in (car, None), (result.car_number, result.reads, result.reason)


@FUZZ
@given(cars, st.integers(0, 2**32 - 1), st.lists(st.integers(0, 10**6), max_size=40))
def test_manchester_corrupted_never_another_car(car: int, seed: int, flips: list[int]) -> None:
    rng = np.random.default_rng(seed)
    passage = manchester_passage(car, rng=rng)
    samples = list(passage["samples"])
    for f in flips:
        samples[f % len(samples)] ^= 1
    result = manchester.decode_passage(samples, samples_per_bit=passage["samples_per_bit"])
    assert result.car_number in (car, None), (result.car_number, result.numbers)


@FUZZ
@given(st.integers(1, 255), st.integers(0, 2**32 - 1), st.lists(any_number, min_size=8, max_size=8))
def test_wheel_marks_one_bad_axle_never_another_car(code: int, seed: int, bad: list[Any]) -> None:
    """One axle of four read as arbitrary garbage (a damaged mark): the code or no code."""
    rng = np.random.default_rng(seed)
    passage = wheel_mark_passage(code, direction=1, rng=rng)
    axles = [list(a) for a in passage["axles"]]
    axles[int(rng.integers(0, len(axles)))] = bad
    result = _result_or_clear_error(
        lambda: wheel_marks.decode_passage(passage["baseline"], axles, direction=1)
    )
    assert result is None or result.code in (code, None), (result.code, result.reason)


DTYPES = st.sampled_from([np.uint8, np.int16, np.int64, np.float32, np.float64, np.bool_])


@FUZZ
@given(
    hnp.arrays(
        DTYPES,
        hnp.array_shapes(min_dims=0, max_dims=4, min_side=0, max_side=48),
        elements=None,
    )
)
def test_tail_detect_any_array(image: np.ndarray) -> None:
    result = _result_or_clear_error(lambda: tail_check.detect(image))
    assert result is None or result.verdict in ("present", "absent", "uncertain")


@FUZZ
@given(st.tuples(*[st.integers(0, 255)] * 3), st.integers(16, 120), st.integers(16, 120))
def test_tail_detect_flat_image_shows_no_disc(colour: tuple[int, int, int], h: int, w: int) -> None:
    """A flat picture (lens covered, fog, a wall) holds no disc: never ``present``."""
    image = np.empty((h, w, 3), np.uint8)
    image[:] = colour
    assert tail_check.detect(image).verdict != "present"


@pytest.mark.parametrize("bad", [None, "image", [[1, 2, 3]], np.zeros((0, 0, 3), np.uint8)])
def test_tail_detect_names_bad_input(bad: Any) -> None:
    with pytest.raises(CLEAR):
        tail_check.detect(bad)
