"""Two defects of the fusion filter (seed 004) left open by the independent trial.

* An on-board unit that reboots starts its clock ``t`` again from near zero in
  the middle of the stream.  The filter refused every later sample as older
  than its buffer, for good.  Now a run of samples far behind the newest one,
  in order among themselves, is taken as a restart: the filter starts again
  with speed and position unknown and recovers from the next good samples.  A
  stray old sample (or a few slightly late ones) is still refused.
* The GNSS speed is a magnitude.  The filter took the sign of its own estimate
  at the first GNSS speed, i.e. forward: a train shunting backwards from the
  start was reported moving forwards, its position running the wrong way.
  Now the direction stays unknown (0, position not known) until evidence: two
  position fixes along the track, a standstill, or a known start.
"""

from __future__ import annotations

import contextlib
import json
import math
from typing import Any

import pytest

from motion.fusion import FilterConfig, Marker, MarkerTable, StaleSampleError, TrackFilter

# A start known to run forwards at 15 m/s from coordinate 0 (with the speed unknown
# at the start, the direction and so the position would not be known).
KNOWN_CRUISE = FilterConfig(initial_position_m=0.0, initial_speed_mps=15.0, initial_speed_sigma=0.5)


def _speed_known(f: TrackFilter) -> bool:
    st = f.state
    assert st is not None
    return st.sigma_speed_mps <= f.cfg.lost_speed_sigma


def _cruise(f: TrackFilter, start: float, seconds: int, speed: float = 15.0) -> None:
    for k in range(seconds):
        f.step(start + k, 0.0, speed, 1.0)


def _as_the_service(f: TrackFilter, *args: Any) -> TrackFilter:
    """One sample as ``service.trains.service.feed`` applies it: the filter
    restored from its JSON snapshot, stepped, and snapshotted again (also when
    the sample is refused)."""
    g = TrackFilter.from_dict(json.loads(json.dumps(f.to_dict())), f.table)
    with contextlib.suppress(StaleSampleError):
        g.step(*args)
    return TrackFilter.from_dict(json.loads(json.dumps(g.to_dict())), f.table)


# -- on-board restart ------------------------------------------------------------------------


def test_a_reboot_mid_stream_is_detected_and_the_filter_recovers() -> None:
    f = TrackFilter(config=KNOWN_CRUISE)
    _cruise(f, 0.0, 300)
    assert f.state is not None and f.state.position_known and _speed_known(f)
    refused, states = 0, []
    for k in range(20):  # the unit rebooted: its clock starts again at 0.3 s
        try:
            states.append(f.step(0.3 + k, 0.0, 15.0, 1.0))
        except StaleSampleError:
            refused += 1
    # only the samples that confirm the restart are lost
    assert refused == f.cfg.restart_confirm_samples - 1
    first = states[0]
    assert not first.position_known and first.direction == 0
    assert first.sigma_speed_mps > f.cfg.lost_speed_sigma  # speed unknown: a person must look
    last = states[-1]
    assert _speed_known(f) and abs(last.speed_mps - 15.0) < 0.2 and last.t == 19.3
    assert not last.position_known  # nothing has fixed the position since the restart


def test_a_reboot_is_recovered_through_the_snapshot_the_service_keeps() -> None:
    f = TrackFilter(config=KNOWN_CRUISE)
    _cruise(f, 0.0, 100)
    for k in range(20):
        f = _as_the_service(f, 0.5 + k, 0.0, 15.0, 1.0)
    assert f.state is not None and f.state.t == 19.5
    assert _speed_known(f) and abs(f.state.speed_mps - 15.0) < 0.2


def test_ordinary_late_samples_are_still_refused() -> None:
    """Samples a few seconds older than the buffer are late, not a restart:
    refused however many there are, the estimate kept."""
    f = TrackFilter(config=KNOWN_CRUISE)
    _cruise(f, 0.0, 300)
    before = f.state
    for k in range(10):
        with pytest.raises(StaleSampleError):
            f.step(285.0 + 0.5 * k, 0.0, 15.0, 1.0)
    assert f.state == before


def test_stray_old_samples_between_live_ones_do_not_restart() -> None:
    """A late old batch interleaved with the live stream must not wipe a good estimate."""
    f = TrackFilter(config=KNOWN_CRUISE)
    _cruise(f, 0.0, 300)
    for k in range(10):
        with pytest.raises(StaleSampleError):
            f.step(10.0 + k, 0.0, 15.0, 1.0)  # old, far behind, in order among themselves
        f.step(300.0 + k, 0.0, 15.0, 1.0)  # the live stream goes on
    assert f.state is not None and f.state.position_known and f.state.t == 309.0


def test_old_samples_out_of_order_among_themselves_do_not_restart() -> None:
    f = TrackFilter(config=KNOWN_CRUISE)
    _cruise(f, 0.0, 300)
    for t in (50.0, 20.0, 40.0, 10.0, 30.0, 5.0):
        with pytest.raises(StaleSampleError):
            f.step(t, 0.0, 15.0, 1.0)
    assert f.state is not None and f.state.position_known and f.state.t == 299.0


# -- direction unknown until evidence ------------------------------------------------------


def _yard() -> MarkerTable:
    """A yard track with a marker every 25 m (and geographic positions)."""
    lat0, lon0 = 50.45, 30.52
    k = 1.0 / (6_371_000.0 * math.cos(math.radians(lat0)))
    ms = [Marker(f"Y{i}", 25.0 * i, lat0, lon0 + math.degrees(25.0 * i * k)) for i in range(41)]
    return MarkerTable(ms)


def _geo(s: float) -> tuple[float, float]:
    lat0, lon0 = 50.45, 30.52
    return lat0, lon0 + math.degrees(s / (6_371_000.0 * math.cos(math.radians(lat0))))


def _shunt_back(f: TrackFilter, *, markers: bool, fixes: bool, seconds: float = 40.0) -> list:
    """The train runs backwards at 3 m/s from coordinate 800 m; GNSS speed
    (a magnitude) each second; marker reads when a marker is passed; GNSS
    fixes (on time) each sample when ``fixes``."""
    out = []
    passed = {round(800.0 / 25.0)}
    for k in range(int(seconds * 10)):
        t = 0.1 * k
        s = 800.0 - 3.0 * t
        mark = None
        idx = math.floor(s / 25.0 + 1e-9)
        if markers and idx not in passed and s <= 25.0 * idx + 1e-9:
            passed.add(idx)
            mark = f"Y{idx}"
        g = 3.0 if k % 10 == 0 else None
        lat, lon = _geo(s) if fixes else (None, None)
        st = f.step(t, 0.0, g, 0.0, mark, lat, lon)
        out.append((t, s, st))
    return out


@pytest.mark.parametrize(("markers", "fixes"), [(True, False), (False, True)])
def test_a_train_backing_from_the_start_is_never_reported_forward(
    markers: bool, fixes: bool
) -> None:
    f = TrackFilter(_yard(), FilterConfig(initial_position_m=800.0))
    run = _shunt_back(f, markers=markers, fixes=fixes)
    for t, s, st in run:
        assert st.direction != 1, (t, st)
        assert st.speed_mps <= 0.0 or st.direction == 0, (t, st)
        if st.position_known:  # a position it states must hold the truth
            assert abs(st.position_m - s) <= 3.0 * st.sigma_position_m + 1.0, (t, s, st)
    t, s, last = run[-1]
    assert last.direction == -1 and last.speed_mps == pytest.approx(-3.0, abs=0.1)
    assert last.position_known and last.position_m == pytest.approx(s, abs=15.0)


def test_while_the_direction_is_unknown_none_is_claimed() -> None:
    """GNSS speed alone (no fix, no marker): the speed is known, its direction not."""
    f = TrackFilter(config=FilterConfig(initial_position_m=800.0))
    for k in range(300):
        st = f.step(0.1 * k, 0.0, 3.0 if k % 10 == 0 else None, 0.0)
    assert _speed_known(f) and abs(abs(st.speed_mps) - 3.0) < 0.1
    assert st.direction == 0 and st.speed_mps >= 0.0  # a magnitude, no direction
    assert not st.position_known  # 800 ± 90 m: it may have gone either way


def test_a_known_standing_start_gives_the_direction_from_the_accelerometer() -> None:
    f = TrackFilter(config=FilterConfig(initial_position_m=800.0, initial_speed_sigma=0.05))
    v = s = 0.0
    for k in range(1, 201):
        a = -0.3 if k <= 100 else 0.0
        s += v * 0.1 + 0.5 * a * 0.01
        v += a * 0.1
        st = f.step(0.1 * k, a, abs(v) if k % 10 == 0 else None, 0.0)
    assert st.direction == -1 and st.speed_mps == pytest.approx(-3.0, abs=0.1)
    assert st.position_known and st.position_m == pytest.approx(800.0 + s, abs=2.0)


def test_a_standstill_settles_the_direction() -> None:
    """Unknown start, GNSS says standing: moving off, the accelerometer tells the way."""
    f = TrackFilter(config=FilterConfig(initial_position_m=800.0))
    v = 0.0
    for k in range(1, 401):
        a = 0.0 if k <= 100 else (-0.3 if k <= 200 else 0.0)
        v += a * 0.1
        st = f.step(0.1 * k, a, abs(v) if k % 10 == 0 else None, 0.0)
    assert st.direction == -1 and st.speed_mps == pytest.approx(-3.0, abs=0.1)


def test_the_unknown_direction_survives_the_snapshot() -> None:
    table = _yard()
    f = TrackFilter(table, FilterConfig(initial_position_m=800.0))
    for k in range(30):
        f.step(0.1 * k, 0.0, 3.0 if k % 10 == 0 else None, 0.0)
    g = TrackFilter.from_dict(json.loads(json.dumps(f.to_dict())), table)
    assert g.state == f.state and g.state is not None and g.state.direction == 0
    for k in range(30, 60):
        a = f.step(0.1 * k, 0.0, 3.0 if k % 10 == 0 else None, 0.0)
        b = g.step(0.1 * k, 0.0, 3.0 if k % 10 == 0 else None, 0.0)
    assert a == b
