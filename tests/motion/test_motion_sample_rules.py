"""The motion-sample rules (``motion.samples``): one set, used by the filter
and by the API schema; each rule names the field it refuses."""

from __future__ import annotations

import math

import pytest

from motion.fusion import TrackFilter
from motion.samples import (
    SAMPLE_LIMITS,
    SampleLimits,
    SampleRuleError,
    check_sample,
    sample_problem,
)

NAN, INF = math.nan, math.inf


@pytest.mark.parametrize(
    ("sample", "field"),
    [
        ((NAN, 0.1, None, None, None, None), "t"),
        ((0.0, INF, None, None, None, None), "accel_mps2"),
        ((0.0, -50.01, None, None, None, None), "accel_mps2"),
        ((0.0, 0.1, 200.0, None, None, None), "gnss_speed_mps"),
        ((0.0, 0.1, -INF, None, None, None), "gnss_speed_mps"),
        ((0.0, 0.1, 3.0, 600.5, None, None), "gnss_delay_s"),
        ((0.0, 0.1, None, NAN, None, None), "gnss_delay_s"),
        ((0.0, 0.1, None, None, 50.0, None), "gnss_lon"),
        ((0.0, 0.1, None, None, None, 30.0), "gnss_lat"),
        ((0.0, 0.1, None, None, 90.01, 30.0), "gnss_lat"),
        ((0.0, 0.1, None, None, 50.0, -180.01), "gnss_lon"),
        ((0.0, 0.1, None, None, 50.0, NAN), "gnss_lon"),
    ],
)
def test_each_rule_names_its_field_and_the_filter_refuses_it(
    sample: tuple[float | None, ...], field: str
) -> None:
    t, a, speed, delay, lat, lon = sample
    assert t is not None and a is not None
    problem = sample_problem(t, a, speed, delay, lat, lon)
    assert problem is not None and problem[0] == field and field in problem[1]
    with pytest.raises(SampleRuleError) as raised:
        check_sample(t, a, speed, delay, lat, lon)
    assert raised.value.field == field
    f = TrackFilter()
    with pytest.raises(ValueError, match=field):
        f.step(t, a, speed, delay, None, lat, lon)
    assert f.state is None  # refused as a whole: nothing of it was applied


def test_the_edges_are_valid_and_the_limits_are_one_object() -> None:
    lim = SAMPLE_LIMITS
    edges = [
        (0.0, lim.max_abs_accel_mps2, math.nextafter(lim.max_gnss_speed_mps, 0.0), 0.0, None, None),
        (-1e6, -lim.max_abs_accel_mps2, 0.0, lim.max_gnss_delay_s, 90.0, -180.0),
        (1e6, 0.0, None, None, -90.0, 180.0),
    ]
    for t, a, speed, delay, lat, lon in edges:
        assert sample_problem(t, a, speed, delay, lat, lon) is None
        check_sample(t, a, speed, delay, lat, lon)
    stricter = SampleLimits(max_gnss_speed_mps=100.0)
    assert sample_problem(0.0, 0.1, 150.0, None, None, None) is None
    assert sample_problem(0.0, 0.1, 150.0, None, None, None, limits=stricter) is not None
