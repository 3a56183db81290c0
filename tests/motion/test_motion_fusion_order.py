"""Samples out of order and clocks that jump forward (found by the independent trial).

* A batch whose samples arrive out of order lost some of them although they were late by
  less than the documented bound (``FilterConfig.max_delay_s``): the first samples of a
  stream, older than the first one applied, were refused.  Every sample up to
  ``max_delay_s`` behind the newest is used; an older one is refused with a reason that
  names the bound.
* One sample far ahead of the newest (a corrupt time stamp) made everything unknown at
  once, and the good samples after it were then "old".  A forward jump needs
  confirmation as an on-board restart does (``restart_confirm_samples`` samples in a
  row, running forward among themselves); fewer are refused, the estimate kept.
"""

from __future__ import annotations

import numpy as np
import pytest

from motion.fusion import FilterConfig, StaleSampleError, TrackFilter

RATE_HZ = 10.0
KNOWN_CRUISE = FilterConfig(initial_position_m=0.0, initial_speed_mps=15.0, initial_speed_sigma=0.5)


def _sample(k: int) -> tuple[float, float, float | None, float | None]:
    t = k / RATE_HZ
    gnss = (15.0, 1.0) if k % int(RATE_HZ) == 0 and t >= 1.0 else (None, None)
    return t, 0.0, *gnss


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_samples_late_within_the_bound_are_all_used(seed: int) -> None:
    """60 s at 10 Hz, each sample delayed by up to 0.8·max_delay_s (uniform)."""
    rng = np.random.default_rng(seed)
    f = TrackFilter(config=FilterConfig())
    late_by = rng.uniform(0.0, 0.8 * f.cfg.max_delay_s, 600)
    order = sorted(range(600), key=lambda k: k / RATE_HZ + late_by[k])
    newest = -1.0
    for k in order:
        t, *rest = _sample(k)
        assert newest - t <= f.cfg.max_delay_s
        f.step(t, *rest)  # never refused
        newest = max(newest, t)
    st = f.state
    assert st is not None and st.t == pytest.approx(59.9)
    assert abs(st.speed_mps - 15.0) < 0.2


def test_a_sample_later_than_the_bound_is_refused_naming_it() -> None:
    f = TrackFilter(config=KNOWN_CRUISE)
    for k in range(200):
        f.step(*_sample(k))
    before = f.state
    with pytest.raises(StaleSampleError, match="max_delay_s"):
        f.step(19.9 - f.cfg.max_delay_s - 2.0, 0.0)
    assert f.state == before


def test_one_sample_far_ahead_does_not_wipe_the_estimate() -> None:
    f = TrackFilter(config=KNOWN_CRUISE)
    for k in range(300):
        f.step(*_sample(k))
    assert f.state is not None and f.state.position_known
    with pytest.raises(StaleSampleError, match="ahead"):
        f.step(1e9, 0.0)
    st = f.state
    assert st is not None and st.position_known and st.t == pytest.approx(29.9)
    # the stream goes on where it was
    for k in range(300, 320):
        st = f.step(*_sample(k))
    assert st.position_known and abs(st.position_m - 15.0 * 31.9) < 5.0


def test_a_confirmed_forward_jump_starts_again_unknown() -> None:
    f = TrackFilter(config=KNOWN_CRUISE)
    for k in range(300):
        f.step(*_sample(k))
    n = f.cfg.restart_confirm_samples
    for i in range(n - 1):
        with pytest.raises(StaleSampleError, match="ahead"):
            f.step(1e6 + i, 0.0)
    st = f.step(1e6 + n - 1, 0.0)
    assert not st.position_known and st.direction == 0 and st.t == 1e6 + n - 1
    for i in range(n, n + 6):
        st = f.step(1e6 + i, 0.0, 15.0, 1.0)
    assert abs(st.speed_mps - 15.0) < 0.2


def test_a_jump_run_broken_by_a_live_sample_starts_over() -> None:
    f = TrackFilter(config=KNOWN_CRUISE)
    for k in range(300):
        f.step(*_sample(k))
    for i in range(f.cfg.restart_confirm_samples * 3):
        with pytest.raises(StaleSampleError):
            f.step(1e6 + i, 0.0)
        f.step(*_sample(300 + i))  # the live clock in between
    st = f.state
    assert st is not None and st.position_known
