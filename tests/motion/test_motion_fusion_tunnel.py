"""A GNSS speed that falls to 0 in a tunnel while the accelerometer shows no braking
(found by the independent trial: after five rejected readings the filter "started
again" from GNSS and reported the train standing, σ 0.05 m/s, while it ran at 20 m/s).

A lost or frozen fix reads 0; no train loses 20 m/s in a second.  The fused speed must
not follow a change of speed faster than any brake gives
(``motion.braking_limits.BRAKING_LIMITS.max_deceleration_mps2``); the state says that
GNSS disagrees, and the speed's σ is the dead-reckoning one (never narrowed by the
refused readings).  A GNSS speed that falls at a rate a brake can give is still
followed, even when the accelerometer missed it (a stuck sensor).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from motion.braking_limits import BRAKING_LIMITS
from motion.fusion import FilterConfig, TrackFilter, TrackState

RATE_HZ = 10.0
DELAY_S = 1.0
CRUISE_MPS = 20.0


def _drive(
    seconds: float,
    true_speed: Callable[[float], float],
    gnss: Callable[[float], float],
    accel: Callable[[float], float],
    *,
    seed: int = 5,
) -> list[TrackState]:
    """10 Hz accelerometer (bias 0.02, noise 0.05), GNSS 1 Hz 1 s late (noise 0.03)."""
    rng = np.random.default_rng(seed)
    f = TrackFilter(config=FilterConfig(gnss_delay_s=DELAY_S))
    states = []
    for k in range(int(seconds * RATE_HZ)):
        t = k / RATE_HZ
        g = None
        if k % int(RATE_HZ) == 0 and t >= DELAY_S:
            g = max(0.0, gnss(t - DELAY_S) + rng.normal(0.0, 0.03))
        a = accel(t) + 0.02 + rng.normal(0.0, 0.05)
        states.append(f.step(t, a, g, DELAY_S if g is not None else None))
    return states


def _cruise(t: float) -> float:
    return CRUISE_MPS


def _level(t: float) -> float:
    return 0.0


def _lost_at_60(t: float) -> float:
    return CRUISE_MPS if t < 60.0 else 0.0


def _largest_deceleration(states: list[TrackState], after_s: float) -> float:
    late = [s for s in states if s.t >= after_s]
    speeds = np.array([s.speed_mps for s in late])
    times = np.array([s.t for s in late])
    return float(np.max(-np.diff(speeds) / np.diff(times)))


def test_a_gnss_speed_falling_to_zero_in_a_second_is_not_followed() -> None:
    states = _drive(120.0, _cruise, _lost_at_60, _level)
    before = next(s for s in states if s.t >= 60.0)
    last = states[-1]
    assert abs(last.speed_mps - CRUISE_MPS) <= 3 * last.sigma_speed_mps, last
    assert abs(last.speed_mps - CRUISE_MPS) < 0.5
    assert _largest_deceleration(states, 55.0) <= BRAKING_LIMITS.max_deceleration_mps2
    assert last.gnss_disagrees and last.as_dict()["gnss_disagrees"] is True
    # dead reckoning for a minute: σ grows, never narrowed by the refused readings
    assert last.sigma_speed_mps >= before.sigma_speed_mps
    assert all(s.sigma_speed_mps >= before.sigma_speed_mps * 0.999 for s in states if s.t > 62)


def test_gnss_back_after_the_tunnel_agrees_again() -> None:
    def tunnel(t: float) -> float:
        return 0.0 if 60.0 <= t < 90.0 else CRUISE_MPS

    states = _drive(120.0, _cruise, tunnel, _level)
    inside = [s for s in states if 70.0 <= s.t < 90.0]
    assert all(s.gnss_disagrees for s in inside)
    last = states[-1]
    assert not last.gnss_disagrees and "gnss_disagrees" not in last.as_dict()
    assert abs(last.speed_mps - CRUISE_MPS) < 0.2 and last.sigma_speed_mps < 0.2


def test_a_braking_the_accelerometer_missed_is_still_followed() -> None:
    """A stuck accelerometer (reads the level) while the train brakes at 1 m/s² from
    t = 60 s: GNSS falls at a rate a brake gives, so after its run of rejections the
    speed starts again from it, as before."""

    def braking(t: float) -> float:
        return max(0.0, CRUISE_MPS - 1.0 * max(0.0, t - 60.0))

    states = _drive(90.0, braking, braking, _level)
    last = states[-1]
    assert abs(last.speed_mps - braking(last.t)) < 1.0 + 3 * last.sigma_speed_mps, last
    assert not last.gnss_disagrees


def test_a_real_braking_seen_by_both_is_followed() -> None:
    def braking(t: float) -> float:
        return max(0.0, CRUISE_MPS - 1.2 * max(0.0, t - 60.0))

    def decel(t: float) -> float:
        return -1.2 if 60.0 <= t < 60.0 + CRUISE_MPS / 1.2 else 0.0

    states = _drive(100.0, braking, braking, decel)
    last = states[-1]
    assert abs(last.speed_mps) < 0.2 and not last.gnss_disagrees
    assert not any(s.gnss_disagrees for s in states)
